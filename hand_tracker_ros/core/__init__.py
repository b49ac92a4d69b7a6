"""Types shared by the layers above the sensors and the model (see docs/architecture.md).

The frame set, the per-camera observations, the model as each camera sees it, the context of
one correspondence round, the energy protocol and the track result. Nothing here imports
``energies``, ``optim``, ``tracking`` or anything above them.
"""
