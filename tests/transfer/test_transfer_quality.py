"""What expressions are worth on a warped paper-sized rig (Carrigan et al. 2020, sec. 5.2, Figs. 9-10)."""

from __future__ import annotations

import transfer

PREFIXES = (0, 1, 2, 4, 7, 10)


def test_error_falls_as_expressions_are_added_and_ebfr_beats_dt(female_pair, packing):
    template, target = female_pair
    weights = packing(template, max(PREFIXES))
    examples = transfer.training_expressions(target, weights)
    baselines = {
        name: transfer.rms(transfer.get(name)(template, target.neutral), target.deltas)
        for name in ("delta", "dt")
    }
    print(f"\nfemale ({template.n_vertices} vertices, {template.n_shapes} shapes), warp alien")
    print("  " + ", ".join(f"{name} rms {value:.5f}" for name, value in baselines.items()))
    print("   J  covered   ebfr rms  (covered / uncovered)   plbs rms")
    errors = []
    for count in PREFIXES:
        used = weights[:count]
        ebfr = transfer.metrics(
            transfer.get("ebfr")(template, target.neutral, used, examples[:count]), target.deltas, used
        )
        plbs_deltas = transfer.get("plbs")(template, target.neutral, used, examples[:count])
        plbs = transfer.rms(plbs_deltas, target.deltas)
        errors.append(ebfr.rms)
        print(
            f"  {count:2d}  {ebfr.n_covered:7d}   {ebfr.rms:.5f}   ({ebfr.rms_covered:.5f} / "
            f"{ebfr.rms_uncovered:.5f})      {plbs:.5f}"
        )
    assert abs(errors[0] - baselines["dt"]) <= 0.02 * baselines["dt"]
    assert all(later <= earlier * (1 + 1e-9) for earlier, later in zip(errors, errors[1:], strict=False))
    assert errors[-1] < baselines["dt"]
