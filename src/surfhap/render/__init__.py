"""surfhap.render."""
