"""Names of the files and folders that reports write and look for, importable without any dependency.

The commands (`reports.cli`) show them in their help, which ``harness --help`` imports; the writers use them.
"""

#: Folder inside a run directory that receives its report.
REPORT_DIR = "report"
