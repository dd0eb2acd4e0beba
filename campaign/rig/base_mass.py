"""The arm's effective mass on either base of the rig: eq 7 on the fixed base, eq 8 on the
flexible scene's emulated base body, as the rig builds it.

In the impulsive phase the beam's spring and damper transmit no impulse, so on the flexible
base the arm stands on a free rigid body: the platform plus the beam's tip share of its mass
(:meth:`campaign.rig.beam.Beam.base_body`), the arm's base frame ``flexible.mount_height``
above the beam tip.
"""

from __future__ import annotations

from ..core.vocabulary import FIXED, FLEXIBLE
from ..model.exiit import effective_mass
from ..model.robot.floating import BaseBody, attach_to_floating_base
from ..scene.description import make_scene
from .beam import Beam

__all__ = ["flexible_base_body", "mass_on_base"]


def flexible_base_body(rig_path=None) -> BaseBody:
    """The emulated base body of the flexible scene, exactly as the rig builds it.

    Platform (``flexible.platform_mass`` [kg], ``flexible.platform_inertia`` [kg m^2]) plus
    the beam's tip share of its mass (:meth:`campaign.rig.beam.Beam.base_body`), the arm's
    base frame ``flexible.mount_height`` [m] above the beam tip.

    Parameters
    ----------
    rig_path : str or Path, optional
        Rig parameter file; default ``config/rig.yaml``.

    Returns
    -------
    campaign.model.robot.floating.BaseBody
    """
    return Beam.from_scene(make_scene(base=FLEXIBLE, rig=rig_path)).base_body()


def mass_on_base(robot, q, *, lam, n, base: str = FIXED, base_body=None) -> float:
    """Effective mass [kg] of ``robot`` at DH angles ``q`` [rad] (eq 11, ``inf`` off range).

    Parameters
    ----------
    robot : campaign.model.robot.Robot
    q : array_like, shape (nv,)
        DH joint angles [rad].
    lam : array_like, shape (nv,)
        Diagonal Virtual Rotor Inertia [kg m^2].
    n : array_like, shape (3,)
        Impact direction in the arm's base frame.
    base : {"fixed", "flexible"}
        Eq 7 or eq 8.
    base_body : BaseBody, optional
        Base of the flexible case; default :func:`flexible_base_body`.
    """
    if base == FIXED:
        return effective_mass(robot, q, n, lam)
    if base == FLEXIBLE:
        frobot = attach_to_floating_base(robot, flexible_base_body() if base_body is None else base_body)
        return effective_mass(frobot, q, n, lam)
    raise ValueError(f"unknown base {base!r}; expected 'fixed' or 'flexible'")
