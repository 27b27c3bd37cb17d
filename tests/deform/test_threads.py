"""The solvers run with one BLAS thread and leave the process's setting as it was."""
import numpy as np
import pytest

threadpoolctl = pytest.importorskip("threadpoolctl")

import puppet.deform.threads as threads  # noqa: E402
from puppet.deform import arap_precompute, arap_solve  # noqa: E402
from tests.deform.meshes import l_shape, nearest  # noqa: E402


def blas_threads():
    return sorted({p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"})


@pytest.fixture
def two_threads():
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        yield


def test_a_solve_caps_blas_and_restores_it(two_threads):
    if blas_threads() != [2]:
        pytest.skip("no BLAS pool that can run 2 threads here")
    V, F = l_shape()
    b = nearest(V, [[1, 1], [19, 1], [1, 19]])
    data = arap_precompute(V, F, b)
    seen = []
    U = arap_solve(data, V[b] + 1.0, iterations=2, callback=lambda it, U: seen.append(blas_threads()))
    assert seen == [[1], [1]]  # inside the solve (the callback runs there)
    assert blas_threads() == [2]  # and restored after it
    assert np.isfinite(U).all()


def test_nesting_keeps_the_cap_until_the_outermost_returns(two_threads):
    if blas_threads() != [2]:
        pytest.skip("no BLAS pool that can run 2 threads here")
    with threads.one_blas_thread():
        with threads.one_blas_thread():
            assert blas_threads() == [1]
        assert blas_threads() == [1]
    assert blas_threads() == [2]


def test_cap_can_be_switched_off(two_threads, monkeypatch):
    monkeypatch.setattr(threads, "BLAS_THREADS", None)
    with threads.one_blas_thread():
        assert blas_threads() == [2] or blas_threads() == []


def test_wrapped_entry_points_keep_their_signatures():
    import inspect

    assert "callback" in inspect.signature(arap_solve).parameters
    assert arap_solve.__name__ == "arap_solve" and "Deform the mesh" in arap_solve.__doc__


def test_the_command_sets_one_blas_thread_before_numpy_loads():
    import os
    import subprocess
    import sys
    code = ("import puppet.cli, numpy, scipy.linalg\n"
            "from threadpoolctl import threadpool_info\n"
            "from puppet.deform import threads\n"
            "print(sorted({i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'}),"
            " threads._limit() is None)")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "PUPPET_BLAS_SET_AT_START")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert out.split() == ["[1]", "True"], out
    env["OPENBLAS_NUM_THREADS"] = "2"  # the user's own choice is kept, and the solvers still cap it
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert out.split() == ["[2]", "False"], out
