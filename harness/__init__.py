"""The `harness` command: experiment grid, executors, records, resume."""
