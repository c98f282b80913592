"""surfhap.live."""
