"""The native .npz format: exact keys, bit-exact round trip, and one-line errors for bad archives."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import rigs
from rigs import Rig, RigError


def small_rig(n_shapes: int = 3, seed: int = 0, **changes) -> Rig:
    generator = np.random.default_rng(seed)
    values = dict(
        neutral=generator.normal(size=(6, 3)),
        deltas=generator.normal(size=(n_shapes, 6, 3)) * 1e-3,
        triangles=np.array([[0, 1, 2], [2, 3, 4], [3, 4, 5]]),
        names=tuple(f"s{k}" for k in range(n_shapes)),
        regions={"upper_lip": [0, 1], "lower_lip": [4, 5]},
        provenance=rigs.Provenance(source="test", units="cm"),
    )
    values.update(changes)
    return Rig(**values)


def assert_same_arrays(loaded: Rig, original: Rig) -> None:
    for field in ("neutral", "deltas", "triangles"):
        mine, theirs = getattr(loaded, field), getattr(original, field)
        assert mine.dtype == theirs.dtype and mine.shape == theirs.shape
        assert mine.tobytes() == theirs.tobytes()
    assert loaded.names == original.names
    assert loaded.regions.keys() == original.regions.keys()
    for name, indices in original.regions.items():
        np.testing.assert_array_equal(loaded.regions[name], indices)


def test_round_trip_is_bit_exact_with_exactly_the_documented_keys(tmp_path):
    rig = small_rig()
    path = rigs.save(rig, tmp_path / "rig.npz")
    with np.load(path) as archive:
        assert sorted(archive.files) == sorted(
            ["neutral", "deltas", "triangles", "names", "region__upper_lip", "region__lower_lip", "units"]
        )
    loaded = rigs.load(path)
    assert_same_arrays(loaded, rig)
    assert loaded.provenance.format == "npz" and loaded.provenance.source == str(path)
    assert loaded.faces is None
    assert [p.name for p in tmp_path.iterdir()] == ["rig.npz"]


def test_npz_is_loaded_verbatim_without_noise_floor(tmp_path):
    deltas = np.zeros((2, 6, 3))
    deltas[0, 1, 0] = 1e-12
    deltas[1, 2, 2] = 0.3
    rig = small_rig(n_shapes=2, deltas=deltas)
    loaded = rigs.load(rigs.save(rig, tmp_path / "tiny.npz"))
    assert loaded.deltas[0, 1, 0] == 1e-12
    assert loaded.load_report.empty_shapes == ()
    cleaned = rigs.load(tmp_path / "tiny.npz", noise_floor=1e-6)
    assert cleaned.load_report.empty_shapes == ("s0",) and cleaned.load_report.noise.zeroed == {"s0": 1}


def test_empty_rig_and_unicode_names_round_trip(tmp_path):
    empty = small_rig(n_shapes=0)
    assert_same_arrays(rigs.load(rigs.save(empty, tmp_path / "empty.npz")), empty)
    named = small_rig(n_shapes=2, names=("lèvre_haut", "眉"))
    assert rigs.load(rigs.save(named, tmp_path / "named.npz")).names == ("lèvre_haut", "眉")


@settings(max_examples=25, deadline=None)
@given(n_shapes=st.integers(0, 4), seed=st.integers(0, 2**20), scale=st.sampled_from([1e-9, 1.0, 1e6]))
def test_round_trip_property(tmp_path_factory, n_shapes, seed, scale):
    generator = np.random.default_rng(seed)
    rig = small_rig(n_shapes, seed, deltas=generator.normal(size=(n_shapes, 6, 3)) * scale)
    path = tmp_path_factory.mktemp("npz") / "rig.npz"
    assert_same_arrays(rigs.load(rigs.save(rig, path)), rig)


def write_archive(path, **arrays):
    with open(path, "wb") as stream:
        np.savez(stream, **arrays)
    return path


def valid_arrays():
    rig = small_rig()
    return dict(neutral=rig.neutral, deltas=rig.deltas, triangles=rig.triangles, names=np.array(rig.names))


def test_missing_file(tmp_path):
    with pytest.raises(RigError, match=r"nothere\.npz: no such file or folder"):
        rigs.load(tmp_path / "nothere.npz")


def test_not_an_archive(tmp_path):
    path = tmp_path / "junk.npz"
    path.write_text("not a zip")
    with pytest.raises(RigError, match=r"junk\.npz: not a NumPy \.npz archive"):
        rigs.load(path)


def test_missing_and_unexpected_keys(tmp_path):
    arrays = valid_arrays()
    del arrays["names"]
    with pytest.raises(RigError, match=r"nonames\.npz: missing key 'names'"):
        rigs.load(write_archive(tmp_path / "nonames.npz", **arrays))
    with pytest.raises(RigError, match=r"extra\.npz: unexpected key 'faces'"):
        rigs.load(write_archive(tmp_path / "extra.npz", faces=np.zeros(3), **valid_arrays()))


def test_pickled_names_are_refused(tmp_path):
    arrays = valid_arrays()
    arrays["names"] = np.array(["s0", 1, None], dtype=object)
    with pytest.raises(RigError, match=r"pickled\.npz: key 'names' cannot be read without pickle"):
        rigs.load(write_archive(tmp_path / "pickled.npz", **arrays))


def test_bad_content_names_file_and_problem(tmp_path):
    arrays = valid_arrays()
    arrays["deltas"] = arrays["deltas"].copy()
    arrays["deltas"][1, 4, 2] = np.nan
    with pytest.raises(
        RigError, match=r"nan\.npz: blendshape 's1' has a non-finite displacement at vertex 4"
    ):
        rigs.load(write_archive(tmp_path / "nan.npz", **arrays))

    arrays = valid_arrays()
    arrays["deltas"] = arrays["deltas"][:, :5]
    with pytest.raises(RigError, match=r"count\.npz: deltas must have shape \(K, 6, 3\)"):
        rigs.load(write_archive(tmp_path / "count.npz", **arrays))

    arrays = valid_arrays()
    arrays["names"] = np.array(["a", "b", "a"])
    with pytest.raises(RigError, match=r"dup\.npz: duplicate blendshape name 'a'"):
        rigs.load(write_archive(tmp_path / "dup.npz", **arrays))

    arrays = valid_arrays()
    arrays["names"] = np.zeros(3)
    with pytest.raises(RigError, match=r"numbers\.npz: 'names' must be a 1-D string array"):
        rigs.load(write_archive(tmp_path / "numbers.npz", **arrays))


def test_a_known_length_unit_round_trips_and_a_bad_one_is_refused(tmp_path):
    rig = small_rig()
    in_cm = rigs.Rig(
        rig.neutral, rig.deltas, rig.triangles, rig.names, provenance=rigs.Provenance(units="cm")
    )
    path = rigs.save(in_cm, tmp_path / "cm.npz")
    with np.load(path) as archive:
        assert str(archive["units"]) == "cm"
    assert rigs.load(path).provenance.units == "cm"
    unknown = replace(rig, provenance=rigs.Provenance())
    assert rigs.load(rigs.save(unknown, tmp_path / "plain.npz")).provenance.units == "unknown"
    arrays = {"neutral": rig.neutral, "deltas": rig.deltas, "triangles": rig.triangles, "names": rig.names}
    np.savez(tmp_path / "bad.npz", **arrays, units=np.array([1.0, 2.0]))
    with pytest.raises(RigError, match=r"bad\.npz: 'units' must be a text scalar"):
        rigs.load(tmp_path / "bad.npz")
