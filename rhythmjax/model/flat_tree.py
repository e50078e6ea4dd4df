"""Pytrees taken apart for jax's fast C++ dispatch of a per-frame jitted call (the online tracker
and the pedestrians level): array leaves as a flat tuple, the rest as one hashable, interned
static argument."""

from __future__ import annotations

import weakref

import equinox as eqx
import jax


class _Structure:
    """The hashable rest of a pytree, its hash computed once: jit hashes static arguments on
    every call, and hashing an equinox Module walks its fields in Python."""

    __slots__ = ("value", "_hash", "__weakref__")

    def __init__(self, value, value_hash: int | None = None):
        self.value = value
        self._hash = hash(value) if value_hash is None else value_hash

    def __hash__(self):
        return self._hash

    def __eq__(self, other):
        return isinstance(other, _Structure) and (self.value is other.value
                                                  or self.value == other.value)


# Interned structures, held weakly: an entry lives as long as something holds its structure (a
# tracker, or jit's own bounded cache of static arguments), so the table never outgrows them.
# The key is an equal copy, not the structure itself (a key is held strongly).
_INTERNED: weakref.WeakValueDictionary[_Structure, _Structure] = weakref.WeakValueDictionary()


def split(tree):
    """Array leaves (a flat tuple) and the hashable rest, so jax's C++ dispatch skips the Python
    flattening of Config and Carry pytrees that dominates a per-frame call (~3 ms to ~0.1 ms).
    The rest is interned: a later tracker with an equal config gets the very object jit cached,
    so the cache lookup is an identity test, not an equinox tree comparison (~0.6 ms a frame)."""
    dyn, static = eqx.partition(tree, eqx.is_array)
    leaves, treedef = jax.tree.flatten(dyn)
    structure = _Structure((treedef, static))
    interned = _INTERNED.get(structure)
    if interned is None:
        _INTERNED[_Structure(structure.value, structure._hash)] = interned = structure
    return tuple(leaves), interned


def interned_count() -> int:
    """How many distinct structures are interned now (for tests and diagnostics)."""
    return len(_INTERNED)


def join(leaves, structure):
    """The pytree `split` took apart."""
    treedef, static = structure.value
    return eqx.combine(jax.tree.unflatten(treedef, leaves), static)
