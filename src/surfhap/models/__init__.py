"""surfhap.models."""
