"""Setting a sample's values on a base parameter set: shared by the global study, the fast
band's pilot stage and the fleet (so that none of them imports another for it)."""

from __future__ import annotations

from ..params import ADHESION_SCALE, Params, get_value, with_updates

__all__ = ["sample_params"]


def sample_params(base: Params, keys, values) -> Params:
    """``base`` with ``keys`` set to ``values`` (validated once, all together).

    ``adhesion_scale`` multiplies mu_s and mu_c (after any direct setting of them).
    """
    updates = {k: float(v) for k, v in zip(keys, values) if k != ADHESION_SCALE}
    if ADHESION_SCALE in keys:
        scale = float(values[list(keys).index(ADHESION_SCALE)])
        for key in ("friction.mu_static", "friction.mu_coulomb"):
            updates[key] = updates.get(key, get_value(base, key)) * scale
    return with_updates(base, updates)
