"""Many scenes, poses and garment images rendered on Dask (a LocalCluster by default)."""
