"""Placing the batch axis of the classification kernels over the local devices.

`local_mesh(n)` is a 1-D mesh (axis "batch") of the first n local devices; `Placement` puts
arrays on it with `jax.sharding.NamedSharding` split along their first axis (tracks or windows),
so a jitted kernel (`ekf_fused.filter_batch`, `windows.classify_window_block`) runs each device's
share of the rows; the parameters stay replicated. With no mesh, arrays go to the default device
as before. The row counts of the chunks are multiples of the device count (`Placement.rows`).

On CPU, several devices need `jax.config.update("jax_num_cpu_devices", k)` (or
`XLA_FLAGS=--xla_force_host_platform_device_count=k`) before JAX is first used.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec


AXIS = "batch"


def local_mesh(n: int | None = None) -> Mesh:
    """A 1-D mesh (axis `AXIS`) over the first `n` local devices (all when None)."""
    devices = jax.local_devices()
    if n is not None:
        if not 1 <= n <= len(devices):
            raise ValueError(f"asked for {n} devices, {len(devices)} local devices available")
        devices = devices[:n]
    return Mesh(np.asarray(devices), (AXIS,))


class Placement:
    """Where the kernels' batch rows go: `mesh` None (the default device) or a 1-D mesh."""

    def __init__(self, mesh: Mesh | None = None):
        self.mesh = mesh
        self.count = 1 if mesh is None else int(mesh.devices.size)
        self.sharding = None if mesh is None else NamedSharding(mesh, PartitionSpec(AXIS))

    def rows(self, rows: int) -> int:
        """`rows` rounded up to a multiple of the device count."""
        return -(-int(rows) // self.count) * self.count

    def put(self, *arrays):
        """The arrays on the devices, split along their first axis (whose length must be a
        multiple of the device count); a tuple."""
        if self.sharding is None:
            return tuple(jnp.asarray(a) for a in arrays)
        return tuple(jax.device_put(np.asarray(a), self.sharding) for a in arrays)


def placement(devices: int | Mesh | None) -> Placement:
    """`Placement` for `classify_tracks(devices=...)`: None (the default device, unsharded), a
    device count (`local_mesh(devices)`) or a mesh."""
    if devices is None:
        return Placement()
    if isinstance(devices, Mesh):
        return Placement(devices)
    return Placement(local_mesh(int(devices)))
