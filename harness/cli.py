"""The `harness` command line (placeholder)."""


def main() -> None:
    raise SystemExit("harness: not ready")
