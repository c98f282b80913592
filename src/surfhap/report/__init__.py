"""surfhap.report."""
