"""Core data types, errors and file formats."""
