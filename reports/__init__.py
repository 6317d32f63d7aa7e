"""reports package (filled by its issue)."""
