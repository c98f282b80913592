"""surfhap.lab."""
