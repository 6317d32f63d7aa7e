"""Format dispatch for loading and saving rigs (placeholder until the loaders land)."""


def load(path, **options):
    raise NotImplementedError


def save(rig, path):
    raise NotImplementedError
