"""surfhap.sim."""
