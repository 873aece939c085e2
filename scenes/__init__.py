"""rsmbench.scenes — MJCF files and the declarative scene registry."""

__all__: list[str] = []
