"""Placeholder replaced by the solver work (issue 2)."""
class Response:  # noqa: D101
    pass
class History:  # noqa: D101
    pass
def simulate(*args, **kwargs):  # noqa: D103
    raise NotImplementedError("solver not built yet")
