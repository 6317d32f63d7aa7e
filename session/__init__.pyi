"""The public names of `session`, read by type checkers and by its lazy loader (`lazy_loader.attach_stub`):
each is imported from its module on first use."""

from ._files import (
    SHEET_FILE as SHEET_FILE,
)
from ._pack import (
    EXPRESSIONS_FILE as EXPRESSIONS_FILE,
    PackConfig as PackConfig,
    PackResult as PackResult,
    pack as pack,
)
