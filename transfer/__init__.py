"""transfer package (filled by its issue)."""
