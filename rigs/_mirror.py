"""Vertex mirror map (placeholder until packing's symmetry lands)."""


def mirror_map(neutral, **options):
    raise NotImplementedError
