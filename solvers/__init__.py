"""solvers package (filled by its issue)."""
