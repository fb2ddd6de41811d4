"""The Dask example on a LocalCluster of two workers, and the benchmark scripts, at tiny sizes
(speed lives in the scripts' output, not here)."""

import re

import dask_states

import bench_check_states
import bench_fcl_compat
import bench_trimesh


def test_dask_shards_give_the_single_process_answers():
    equal, _, _, rebuilt = dask_states.run(states=3000, workers=2, objects=300, verbose=False)
    assert equal
    assert sorted(rebuilt.values()) == [1, 1]  # each worker rebuilt the world once


def test_benchmark_runs(capsys):
    bench_trimesh.main(["--primitives", "300", "--meshes", "40", "--repeat", "1"])
    out = capsys.readouterr().out
    assert "same on every manager" in out and "targets" in out


def test_fcl_compat_benchmark_runs(capsys):
    # trimesh's manager on cube_collision.fcl and on python-fcl's way give the same names, and
    # the batched poses the single-pose answers (the script exits otherwise)
    bench_fcl_compat.main(["--primitives", "300", "--meshes", "40", "--poses", "50",
                           "--repeat", "1"])
    out = capsys.readouterr().out
    assert "trimesh clash" in out and "poses clash" in out and "targets" in out


def test_check_states_benchmark_runs(capsys):
    # the Python calls give the C++ calls' answers on the same world and body (the script
    # returns 1 otherwise)
    assert bench_check_states.main(["--objects", "300", "--states", "200", "--repeat", "1",
                                    "--threads", "1", "2"]) == 0
    out = capsys.readouterr().out
    assert out.count("check_states ") == 4 and out.count("check_motions ") == 2
    # continuous edges, with SE(3) bounds and with given bounds, per thread count
    assert out.count("check_motions_continuous ") == 4


def test_check_states_benchmark_counts_instructions_under_callgrind(capfd):
    # the script runs itself again under valgrind: one counted call of each side per case, the
    # answers compared first (exit status 1 otherwise)
    assert bench_check_states.main(["--instructions", "--objects", "300", "--states", "200"]) == 0
    lines = [l for l in capfd.readouterr().out.splitlines() if "instructions" in l]
    assert len(lines) == 5
    for line in lines:
        py, cpp = (int(x) for x in re.findall(r"(\d+) instructions", line))
        assert 0 < cpp < py  # the Python call does the C++ call's work and converts its poses
