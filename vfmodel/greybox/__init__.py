"""greybox layer."""
