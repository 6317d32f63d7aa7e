"""Procedural rigs (placeholder until the generator lands)."""

PRESETS: dict = {}


def generate(preset, seed=0):
    raise NotImplementedError
