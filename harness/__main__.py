"""``python -m harness``: the ``harness`` command, for an environment whose scripts folder is not on the
``PATH`` (`harness.cli.main`)."""

from harness.cli import main

main()
