"""`packing.Termination` where a plugin author looks for it: a plugin's ``solve`` says why it stopped, and
imports everything it needs from `solvers` (imported on first use, so that listing plugins imports no
packing code)."""

from packing import Termination as Termination
