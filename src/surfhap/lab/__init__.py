"""Lab tools: display calibration from tribometer recordings, study designs, staircases,
loss-free trial logs, and the paper-style analysis of perception studies."""
