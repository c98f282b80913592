"""surfhap.shape."""
