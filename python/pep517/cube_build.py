"""PEP 517 backend for pip install . : drives the project's CMake, needs nothing from an index.

build_wheel configures the source tree with the Python package on and everything else off, builds
the extension module, and zips the staged package (python/cube_collision + _core*.so) into a
wheel for this interpreter. The build directory is kept for the next install (build-pip/ in the
source tree, or $CUBE_COLLISION_BUILD_DIR). $CMAKE_BUILD_PARALLEL_LEVEL sets the jobs (default
2). Extra CMake arguments: $CUBE_COLLISION_CMAKE_ARGS (split on spaces).
"""

import base64
import hashlib
import os
import subprocess
import sys
import sysconfig
import tarfile
import zipfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def _project():
    meta = {"name": "cube-collision", "version": "0.1.0", "description": "",
            "requires-python": ">=3.9", "dependencies": ["numpy"],
            "optional-dependencies": {}}
    try:
        import tomllib  # Python 3.11+
        with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
            meta.update(tomllib.load(f).get("project", {}))
    except ImportError:
        pass
    return meta


def _dist_name(meta):
    return meta["name"].replace("-", "_")


def _metadata_text(meta):
    lines = ["Metadata-Version: 2.1", f"Name: {meta['name']}", f"Version: {meta['version']}",
             f"Summary: {meta['description']}", f"Requires-Python: {meta['requires-python']}"]
    lines += [f"Requires-Dist: {d}" for d in meta["dependencies"]]
    for extra, deps in meta["optional-dependencies"].items():
        lines.append(f"Provides-Extra: {extra}")
        lines += [f"Requires-Dist: {d}; extra == \"{extra}\"" for d in deps]
    return "\n".join(lines) + "\n"


def _tag():
    impl = f"cp{sys.version_info.major}{sys.version_info.minor}"
    plat = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{impl}-{impl}-{plat}"


def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    meta = _project()
    name = f"{_dist_name(meta)}-{meta['version']}.dist-info"
    os.makedirs(os.path.join(metadata_directory, name), exist_ok=True)
    with open(os.path.join(metadata_directory, name, "METADATA"), "w") as f:
        f.write(_metadata_text(meta))
    return name


def _build():
    build = os.environ.get("CUBE_COLLISION_BUILD_DIR", os.path.join(ROOT, "build-pip"))
    args = ["cmake", "-S", ROOT, "-B", build, "-DCMAKE_BUILD_TYPE=Release",
            "-DCUBE_COLLISION_BUILD_TESTS=OFF", "-DCUBE_COLLISION_BUILD_EXAMPLES=OFF",
            "-DCUBE_COLLISION_BUILD_BENCHMARKS=OFF", "-DCUBE_COLLISION_INSTALL=OFF",
            "-DCUBE_COLLISION_BUILD_PYTHON=ON", f"-DPython3_EXECUTABLE={sys.executable}"]
    args += os.environ.get("CUBE_COLLISION_CMAKE_ARGS", "").split()
    subprocess.run(args, check=True, stdout=sys.stderr)
    jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", "2")
    subprocess.run(["cmake", "--build", build, "--target", "cube_collision_python", "-j", jobs],
                   check=True, stdout=sys.stderr)
    return os.path.join(build, "python", "cube_collision")


def _record_line(path, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{path},sha256={digest},{len(data)}"


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    meta = _project()
    staged = _build()
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    files = ["__init__.py", "__init__.pyi", "_core.pyi", "fcl.py", "py.typed", "_core" + suffix]
    dist = _dist_name(meta)
    info = f"{dist}-{meta['version']}.dist-info"
    wheel_name = f"{dist}-{meta['version']}-{_tag()}.whl"
    entries = []
    for f in files:
        with open(os.path.join(staged, f), "rb") as fh:
            entries.append((f"cube_collision/{f}", fh.read()))
    entries.append((f"{info}/METADATA", _metadata_text(meta).encode()))
    entries.append((f"{info}/WHEEL", (f"Wheel-Version: 1.0\nGenerator: cube_build\n"
                                      f"Root-Is-Purelib: false\nTag: {_tag()}\n").encode()))
    entries.append((f"{info}/top_level.txt", b"cube_collision\n"))
    record = [_record_line(p, d) for p, d in entries] + [f"{info}/RECORD,,"]
    entries.append((f"{info}/RECORD", ("\n".join(record) + "\n").encode()))
    os.makedirs(wheel_directory, exist_ok=True)
    with zipfile.ZipFile(os.path.join(wheel_directory, wheel_name), "w",
                         zipfile.ZIP_DEFLATED) as z:
        for path, data in entries:
            z.writestr(path, data)
    return wheel_name


def build_sdist(sdist_directory, config_settings=None):
    """The source tree less build directories and .git, as name-version.tar.gz."""
    meta = _project()
    base = f"{_dist_name(meta)}-{meta['version']}"
    os.makedirs(sdist_directory, exist_ok=True)

    def keep(info):
        top = info.name.split("/")[1] if "/" in info.name else ""
        return None if top.startswith("build") or top == ".git" or "__pycache__" in info.name \
            else info

    with tarfile.open(os.path.join(sdist_directory, base + ".tar.gz"), "w:gz") as t:
        for entry in sorted(os.listdir(ROOT)):
            t.add(os.path.join(ROOT, entry), arcname=f"{base}/{entry}", filter=keep)
        info = tarfile.TarInfo(f"{base}/PKG-INFO")
        data = _metadata_text(meta).encode()
        info.size = len(data)
        import io
        t.addfile(info, io.BytesIO(data))
    return base + ".tar.gz"
