"""File formats, one module each: materials (JSON, HaTT XML), trajectories, recordings, IMU CSV, meshes, render and shape outputs."""
