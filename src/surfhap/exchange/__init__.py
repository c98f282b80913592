"""surfhap.exchange."""
