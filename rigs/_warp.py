"""Warps (placeholder until the warps land)."""

WARPS: dict = {}


def warp(rig, spec):
    raise NotImplementedError
