"""The Dask example on a LocalCluster of two workers, and the benchmark scripts, at tiny sizes
(speed lives in the scripts' output, not here)."""

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
