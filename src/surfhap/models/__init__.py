"""Material models as data and their evaluation: friction laws, texture banks, the Material schema and the built-in materials."""
