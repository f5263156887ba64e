"""The ``vfmodel`` command line (thin: parse, call, print, exit codes)."""
