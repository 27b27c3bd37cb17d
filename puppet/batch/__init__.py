"""Many scenes, poses and garment images rendered on Dask (a LocalCluster by default).

The client's modules (command, runner, jobs, guard, state, dispatch, work, cluster) import
no numpy when loaded: the scene stack (numpy, scipy) comes in inside the functions that
read scenes, marked ``# lazy``. So a job list gets into
:func:`puppet.batch.runner.run_batch`, which leaves a report however a run is stopped, a
fraction of a second after the command starts (tests/batch/test_safety.py stops one at 0.8 s).
"""
