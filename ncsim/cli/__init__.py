"""The ``ncsim`` command: argument parsing, output and exit codes only."""
