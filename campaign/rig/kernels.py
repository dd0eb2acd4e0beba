"""The plants' dynamics on plain Python floats: what the trial loop evaluates at every RK4 stage.

A trial's state has 9 (fixed base, VES loop) to 21 (ideal coupling) entries; its loop
makes about 2000 evaluations. At that size a NumPy call costs more than its arithmetic
and the Pinocchio call is the only work worth an array, so a kernel takes the state as a
list of floats, fills Pinocchio's inputs into preallocated arrays and does the rest
(joint torques, the contact force, the pendulum, the state derivative) in Python floats:
operation for operation, in the same order, what the plant's array methods
(:meth:`.plant.FixedBasePlant.rhs`, ``evaluate``, ``holding``, ``gap``) compute, so the
numbers are the same bits (``tests/rig/test_lean_loop.py`` compares them). A product
``n^T J v`` of 3-9 terms is summed left to right from 0.0, the order of the BLAS ``ddot``
NumPy calls for it. The per-evaluation comprehensions over the joint torque zip lists of
the arm's length by construction without zip's length check (``strict=False``: the check
costs about 14% of a short comprehension).

Every kernel offers

``stage(x, t, tau, fs, v0, caught)``
    the state derivative (an RK4 stage: :meth:`.plant.FixedBasePlant.rhs`);
``full(x, t, tau, fs, v0, caught)``
    ``(xd, lam, gap)``: the derivative, the stuck joints' holding torques and the contact
    gap ``(delta, ddelta)`` (None once the hammer is caught, out of contact), from one
    dynamics solve (:meth:`.plant.FixedBasePlant.evaluate`);
``holding(x, t, tau, fs, v0)``
    the holding torques alone (:meth:`.plant.FixedBasePlant.holding`);
``gap(x, t)``
    the contact gap from the kinematics alone (:meth:`.plant.FixedBasePlant.gap`);
``servo(tau_arm)``
    the generalised servo torque of the arm's joint torques (a tuple).

with ``tau`` the held servo torque (a tuple, compared by identity: the constant part of the
joint torque is kept until it or the friction modes ``fs`` change), ``v0`` the contact's
approach speed (None out of contact) and ``caught`` the hammer's brake.
"""

from __future__ import annotations

import math
import operator
import struct

import numpy as np
import pinocchio as pin

from .flexible import VesLoopPlant
from .plant import FixedBasePlant, FrictionState

__all__ = ["kernel_for", "FixedKernel", "VesKernel", "ArrayKernel"]

_LWA = pin.LOCAL_WORLD_ALIGNED
_WORLD = pin.Convention.WORLD
_aba, _rnea = pin.aba, pin.rnea


def kernel_for(plant):
    """The kernel of ``plant``: :class:`VesKernel` for the VES loop, :class:`FixedKernel` for
    the fixed base, :class:`ArrayKernel` (the plant's own array methods) otherwise."""
    if isinstance(plant, VesLoopPlant):
        return VesKernel(plant)
    if type(plant) is FixedBasePlant:
        return FixedKernel(plant)
    return ArrayKernel(plant)


def _dot(a, b) -> float:
    """``sum(a_i b_i)`` left to right from 0.0 (BLAS ``ddot``'s order on a few terms)."""
    s = 0.0
    for u, w in zip(a, b, strict=True):
        s += u * w
    return s


def _packer(n: int):
    """``pack(array, offset_bytes, *values)``: ``n`` floats written into an array's memory in
    one call (a NumPy assignment from a list converts each element through the sequence
    protocol and costs 2-3 times as much on a few floats); the same IEEE doubles."""
    return struct.Struct(f"{n}d").pack_into


def _getter(index):
    """``get(seq)``: the tuple of ``seq``'s entries at ``index`` (a tuple for one index too)."""
    if len(index) == 1:
        i = index[0]
        return lambda seq: (seq[i],)
    return operator.itemgetter(*index)


class _Reduced:
    """A partly stuck arm's reduced model (its stuck joints locked) and its inputs: one buffer
    of the free joints' angles, velocities and torques, filled in one call from the state
    and the joint torque lists."""

    __slots__ = ("fs", "model", "data", "free", "buf", "q", "v", "u", "pack", "gq", "gv", "gu", "spread", "zero_v")

    def __init__(self, fs: FrictionState, nv: int):
        self.fs = fs
        self.model, self.data = fs.reduced
        self.free = free = fs.free_l
        n = len(free)
        self.buf = np.zeros(3 * n)
        self.q, self.v, self.u = self.buf[:n], self.buf[n:2 * n], self.buf[2 * n:]
        self.pack = _packer(3 * n)
        self.gq, self.gv, self.gu = _getter(free), _getter([nv + 1 + j for j in free]), _getter(free)
        # spread(a_F + [0.0]): the arm's accelerations, a_F on the free joints and the
        # appended 0.0 on the stuck ones (one C call instead of a loop of assignments)
        self.spread = operator.itemgetter(*[free.index(j) if j in free else n for j in range(nv)])
        self.zero_v = np.zeros(n)


class FixedKernel:
    """:class:`.plant.FixedBasePlant` on float lists (module docstring).

    State ``x = [q (nv), theta, v (nv), thetadot, P]``. Pinocchio reads the state and the
    joint torque from one buffer ``B = [x, u]`` (the angles, velocities and torque are views
    into it; the state part is written once per state list); a partly stuck arm's free
    joints go into a buffer of the reduced model's size (:class:`_Reduced`). The contact
    gap of the last state list is kept (a step end's event check and its evaluations share
    it).
    """

    def __init__(self, plant: FixedBasePlant):
        self.plant = plant
        self.nv = nv = plant.nv
        self.size = size = plant.size
        self.iP = plant.i_P
        self.model, self.data = plant.model, plant.data
        self.fid = plant.fid
        self.visc = np.asarray(plant.viscous, dtype=float).tolist()
        self.r, self.mgl, self.Ip = plant._r, plant._mgl, plant._Ip
        self.k, self.p, self.d = plant._k, plant._p, plant._d
        self.s0 = plant._s0
        self.axis = plant._axis
        self.M_tip = plant._M_tip
        self.i_thd = plant.i_thd
        self.sv = slice(nv + 1, 2 * nv + 1)          # velocities in x
        self.sd = slice(nv + 1, 2 * nv + 2)          # x entries that are the first derivatives
        self.B = np.zeros(size + nv)
        self.Bq, self.Bv, self.Bu = self.B[:nv], self.B[self.sv], self.B[size:]
        self.pack_x, self.pack_xu, self.pack_n = _packer(size), _packer(size + nv), _packer(nv)
        self.off_u = 8 * size                        # byte offset of u in B
        self.A = np.zeros(nv)
        self.filled = None                           # the state list in B
        self.red = None                              # the last partly stuck arm's _Reduced
        self.c2 = (None, None, None)
        self.kin = (None, None)                      # (state list, (delta, ddelta, J_n))

    def servo(self, tau_arm):
        return tuple(tau_arm)

    def _fill(self, x):
        if self.filled is not x:
            self.pack_x(self.B, 0, *x)
            self.filled = x

    def _fill_u(self, x, u):
        """The state list and the joint torque ``u`` into ``B``."""
        if self.filled is x:
            self.pack_n(self.B, self.off_u, *u)
        else:
            self.pack_xu(self.B, 0, *x, *u)
            self.filled = x

    def _reduced(self, fs):
        red = self.red
        if red is None or red.fs is not fs:
            red = self.red = _Reduced(fs, self.nv)
        return red

    # -- kinematics ---------------------------------------------------------------------
    def _gap_jn(self, x, t=0.0):
        """``(delta, ddelta, J_n)``: :meth:`.plant.FixedBasePlant.gap` (J_n as a list)."""
        kin = self.kin
        if kin[0] is x:
            return kin[1]
        self._fill(x)
        J = pin.computeFrameJacobian(self.model, self.data, self.Bq, self.fid, _LWA)
        p = self.M_tip.translation
        if self.axis is not None:
            i, sign = self.axis
            if sign < 0:
                s, Jn = -float(p[i]) - self.s0, (-J[i]).tolist()
            else:
                s, Jn = float(p[i]) - self.s0, J[i].tolist()
        else:
            n = self.plant.n
            s, Jn = float(n @ p) - self.s0, (n @ J[:3]).tolist()
        nv = self.nv
        th, thd = x[nv], x[self.i_thd]
        out = (self.r * math.sin(th) - s, self.r * math.cos(th) * thd - _dot(Jn, x[self.sv]), Jn)
        self.kin = (x, out)
        return out

    def gap(self, x, t=0.0):
        return self._gap_jn(x, t)[:2]

    def _loads(self, x, t, tau_s, fs, v0, with_gap: bool):
        """Joint torque (servo, friction, contact), contact force and gap (or None)."""
        c = self.c2
        if c[0] is not tau_s or c[1] is not fs:
            c = self.c2 = (tau_s, fs, [a - b for a, b in zip(tau_s, fs.coulomb_f, strict=True)])
        tau = [a - b * w for a, b, w in zip(c[2], self.visc, x[self.sv], strict=False)]
        if v0 is None and not with_gap:
            return tau, 0.0, None
        delta, ddelta, Jn = self._gap_jn(x, t)
        F = 0.0
        if v0 is not None and delta > 0.0:     # :meth:`.plant.FixedBasePlant.contact_force`
            F = self.k * delta**self.p * (1.0 + self.d * ddelta / v0)
            if F > 0.0:
                tau = [a + j * F for a, j in zip(tau, Jn, strict=True)]
            else:
                F = 0.0
        return tau, F, (delta, ddelta)

    # -- dynamics -----------------------------------------------------------------------
    def _accel(self, x, t, tau, fs: FrictionState):
        """Accelerations of the constrained dynamics (:meth:`.plant.FixedBasePlant._accel`)."""
        if fs.none_stuck:
            self._fill_u(x, tau)
            return _aba(self.model, self.data, self.Bq, self.Bv, self.Bu, _WORLD).tolist()
        if fs.all_stuck:
            return [0.0] * self.nv
        red = self._reduced(fs)
        red.pack(red.buf, 0, *red.gq(x), *red.gv(x), *red.gu(tau))
        return list(red.spread(_aba(red.model, red.data, red.q, red.v, red.u).tolist() + [0.0]))

    def _lam(self, x, t, a, tau, fs: FrictionState):
        """Holding torques ``rnea(q, v, a)_S - tau_S`` (:meth:`.plant.FixedBasePlant.constrained`)."""
        self._fill(x)
        self.pack_n(self.A, 0, *a)
        r = _rnea(self.model, self.data, self.Bq, self.Bv, self.A).tolist()
        return [r[j] - tau[j] for j in fs.stuck_l]

    def _xd(self, x, a, F, caught):
        if caught:
            return x[self.sd] + a + [0.0, F]
        th = x[self.nv]
        return x[self.sd] + a + [(-self.mgl * math.sin(th) - F * self.r * math.cos(th)) / self.Ip, F]

    def stage(self, x, t, tau_s, fs, v0, caught):
        # an RK4 stage (~2000 a trial): _loads, _accel and _xd inlined, the same operations
        # in the same order (a Python call costs ~0.1 us)
        c = self.c2
        if c[0] is not tau_s or c[1] is not fs:
            c = self.c2 = (tau_s, fs, [a - b for a, b in zip(tau_s, fs.coulomb_f, strict=True)])
        tau = [a - b * w for a, b, w in zip(c[2], self.visc, x[self.sv], strict=False)]
        F = 0.0
        if v0 is not None:
            delta, ddelta, Jn = self._gap_jn(x, t)
            if delta > 0.0:
                F = self.k * delta**self.p * (1.0 + self.d * ddelta / v0)
                if F > 0.0:
                    tau = [a + j * F for a, j in zip(tau, Jn, strict=True)]
                else:
                    F = 0.0
        if fs.none_stuck:
            if self.filled is x:
                self.pack_n(self.B, self.off_u, *tau)
            else:
                self.pack_xu(self.B, 0, *x, *tau)
                self.filled = x
            a = _aba(self.model, self.data, self.Bq, self.Bv, self.Bu, _WORLD).tolist()
        elif fs.all_stuck:
            a = [0.0] * self.nv
        else:
            red = self.red
            if red is None or red.fs is not fs:
                red = self._reduced(fs)
            red.pack(red.buf, 0, *red.gq(x), *red.gv(x), *red.gu(tau))
            a = list(red.spread(_aba(red.model, red.data, red.q, red.v, red.u).tolist() + [0.0]))
        if caught:
            return x[self.sd] + a + [0.0, F]
        th = x[self.nv]
        return x[self.sd] + a + [(-self.mgl * math.sin(th) - F * self.r * math.cos(th)) / self.Ip, F]

    def full(self, x, t, tau_s, fs, v0, caught):
        # one a step end (~1300 a trial): _loads, _lam and _xd inlined, the same operations
        # in the same order
        c = self.c2
        if c[0] is not tau_s or c[1] is not fs:
            c = self.c2 = (tau_s, fs, [a - b for a, b in zip(tau_s, fs.coulomb_f, strict=True)])
        tau = [a - b * w for a, b, w in zip(c[2], self.visc, x[self.sv], strict=False)]
        F, gap = 0.0, None
        if v0 is not None or not caught:
            delta, ddelta, Jn = self._gap_jn(x, t)
            if v0 is not None and delta > 0.0:
                F = self.k * delta**self.p * (1.0 + self.d * ddelta / v0)
                if F > 0.0:
                    tau = [a + j * F for a, j in zip(tau, Jn, strict=True)]
                else:
                    F = 0.0
            gap = (delta, ddelta)
        a = self._accel(x, t, tau, fs)
        if fs.none_stuck:
            lam = []
        else:                                   # _lam
            if self.filled is not x:
                self.pack_x(self.B, 0, *x)
                self.filled = x
            self.pack_n(self.A, 0, *a)
            r = _rnea(self.model, self.data, self.Bq, self.Bv, self.A).tolist()
            lam = [r[j] - tau[j] for j in fs.stuck_l]
        if caught:
            return x[self.sd] + a + [0.0, F], lam, gap
        th = x[self.nv]
        return x[self.sd] + a + [(-self.mgl * math.sin(th) - F * self.r * math.cos(th)) / self.Ip, F], lam, gap

    def holding(self, x, t, tau_s, fs, v0):
        if fs.none_stuck:
            return []
        tau, _, _ = self._loads(x, t, tau_s, fs, v0, False)
        return self._lam(x, t, self._accel(x, t, tau, fs), tau, fs)


class VesKernel(FixedKernel):
    """:class:`.flexible.VesLoopPlant` on float lists (module docstring): the arm on the
    platform whose motion at ``t`` the emulator prescribes (the plant's cached
    :meth:`~.flexible.VesLoopPlant._platform`, compared by identity).

    State ``x = [q_arm (na), theta, v_arm (na), thetadot, P]``. The free-flyer's
    configuration, velocity and acceleration ``[a_b, 0]`` are views into one buffer
    written in one call from the platform motion and the state list; the kinematics and
    the bias torques of the last (state list, platform motion) are kept. The arm's own
    calls (ABA at rest, RNEA of the holding torques) read ``B`` as the fixed base does.
    """

    def __init__(self, plant):
        super().__init__(plant)
        na = self.nv
        self.fmodel, self.fdata, self.ffid = plant.fmodel, plant.fdata, plant.ffid
        self.M_ftip = plant._M_ftip
        self.arm0 = plant._arm0
        self.na0 = plant._na0
        self.zna = (0.0,) * na
        nf = 19 + 3 * na
        self.F = np.zeros(nf)
        self.qf, self.vf, self.af = self.F[:7 + na], self.F[7 + na:13 + 2 * na], self.F[13 + 2 * na:]
        self.pack_f = _packer(nf)
        self.af_ft = np.zeros(6 + na)         # [a_b, a_arm] of an F/T sample
        self.pack_ft = _packer(6 + na)
        self.ffilled = (None, None)           # the (state list, platform motion) in F
        self.bias_last = (None, None, None)   # (state list, platform motion, bias)
        self.kin = (None, None, None)         # (state list, platform motion, (delta, ddelta, J_n))

    def _ffill(self, x, plat):
        """The free-flyer configuration, velocity and acceleration ``[a_b, 0]`` of the
        platform motion ``plat`` and the arm's state ``x``."""
        f = self.ffilled
        if f[0] is not x or f[1] is not plat:
            q7, v6, a6 = plat
            na = self.nv
            self.pack_f(self.F, 0, *q7, *x[:na], *v6, *x[self.sv], *a6, *self.zna)
            self.ffilled = (x, plat)

    def _gap_jn(self, x, t=0.0, plat=None):
        """:meth:`.flexible.VesLoopPlant.gap` with the platform at ``t`` (J_n as a list; the
        platform motion ``plat`` at ``t`` when the caller has it)."""
        if plat is None:
            plat = self.plant._platform(t)
        kin = self.kin
        if kin[0] is x and kin[1] is plat:
            return kin[2]
        self._ffill(x, plat)
        J = pin.computeFrameJacobian(self.fmodel, self.fdata, self.qf, self.ffid, _LWA)
        p = self.M_ftip.translation
        if self.axis is not None:
            i, sign = self.axis
            J, s = (-J[i], -float(p[i])) if sign < 0 else (J[i], float(p[i]))
        else:
            n = self.plant.n
            J, s = n @ J[:3], float(n @ p)
        Jl = J.tolist()
        na = self.nv
        Jn = Jl[6:]
        th, thd = x[na], x[self.i_thd]
        delta = self.r * math.sin(th) - (s - self.s0)
        ddelta = self.r * math.cos(th) * thd - _dot(Jn, x[self.sv]) - _dot(Jl[:6], plat[1])
        out = (delta, ddelta, Jn)
        self.kin = (x, plat, out)
        return out

    def _bias(self, x, t, plat=None):
        """``rnea(q, v, [a_b, 0])_m`` with the platform at ``t`` (:meth:`.flexible.VesLoopPlant._bias`;
        the platform motion ``plat`` at ``t`` when the caller has it)."""
        if plat is None:
            plat = self.plant._platform(t)
        last = self.bias_last
        if last[0] is x and last[1] is plat:
            return last[2]
        self._ffill(x, plat)
        bias = _rnea(self.fmodel, self.fdata, self.qf, self.vf, self.af).tolist()[6:]
        self.bias_last = (x, plat, bias)
        return bias

    def _free_accel(self, x, u, fs):
        """``a`` with ``a_S = 0`` and ``H_FF a_F = u_F`` (:meth:`.flexible.VesLoopPlant._free_accel`)."""
        m0, d0 = self.arm0
        if fs.none_stuck:
            self._fill_u(x, u)
            return _aba(m0, d0, self.Bq, self.na0, self.Bu).tolist()
        red = self._reduced(fs)
        red.pack(red.buf, 0, *red.gq(x), *red.gv(x), *red.gu(u))
        return list(red.spread(_aba(red.model, red.data, red.q, red.zero_v, red.u).tolist() + [0.0]))

    def _constrained(self, x, t, tau, fs, with_lam: bool, plat=None):
        """``(lam, a)`` (:meth:`.flexible.VesLoopPlant.constrained`; ``lam`` empty unless asked)."""
        if fs.all_stuck:
            if not with_lam:
                return [], [0.0] * self.nv
            return [-(a - b) for a, b in zip(tau, self._bias(x, t, plat), strict=True)], [0.0] * self.nv
        u = [a - b for a, b in zip(tau, self._bias(x, t, plat), strict=True)]
        a = self._free_accel(x, u, fs)
        if fs.none_stuck or not with_lam:
            return [], a
        m0, d0 = self.arm0
        self._fill(x)
        self.pack_n(self.A, 0, *a)
        r = _rnea(m0, d0, self.Bq, self.na0, self.A).tolist()
        return [r[j] - u[j] for j in fs.stuck_l], a

    def stage(self, x, t, tau_s, fs, v0, caught):
        # an RK4 stage (~2400 a trial): _loads, _bias, _free_accel and _xd inlined, the
        # platform motion looked up once, the same operations in the same order
        c = self.c2
        if c[0] is not tau_s or c[1] is not fs:
            c = self.c2 = (tau_s, fs, [a - b for a, b in zip(tau_s, fs.coulomb_f, strict=True)])
        tau = [a - b * w for a, b, w in zip(c[2], self.visc, x[self.sv], strict=False)]
        plat = self.plant._platform(t)
        F = 0.0
        if v0 is not None:
            delta, ddelta, Jn = self._gap_jn(x, t, plat)
            if delta > 0.0:
                F = self.k * delta**self.p * (1.0 + self.d * ddelta / v0)
                if F > 0.0:
                    tau = [a + j * F for a, j in zip(tau, Jn, strict=True)]
                else:
                    F = 0.0
        if fs.all_stuck:
            a = [0.0] * self.nv
        else:
            last = self.bias_last
            if last[0] is x and last[1] is plat:
                bias = last[2]
            else:
                f = self.ffilled
                if f[0] is not x or f[1] is not plat:
                    q7, v6, a6 = plat
                    self.pack_f(self.F, 0, *q7, *x[:self.nv], *v6, *x[self.sv], *a6, *self.zna)
                    self.ffilled = (x, plat)
                bias = _rnea(self.fmodel, self.fdata, self.qf, self.vf, self.af).tolist()[6:]
                self.bias_last = (x, plat, bias)
            u = [a - b for a, b in zip(tau, bias, strict=False)]
            if fs.none_stuck:
                a = self._free_accel(x, u, fs)
            else:
                red = self.red
                if red is None or red.fs is not fs:
                    red = self._reduced(fs)
                red.pack(red.buf, 0, *red.gq(x), *red.gv(x), *red.gu(u))
                a = list(red.spread(_aba(red.model, red.data, red.q, red.zero_v, red.u).tolist() + [0.0]))
        if caught:
            return x[self.sd] + a + [0.0, F]
        th = x[self.nv]
        return x[self.sd] + a + [(-self.mgl * math.sin(th) - F * self.r * math.cos(th)) / self.Ip, F]

    def emulator_tick(self, t, x, xd):
        """Sample the F/T wrench at (t, x) with the state derivative ``xd`` and advance the
        emulator (:meth:`.flexible.VesLoopPlant.on_emulator_tick` from the kernel's buffers)."""
        plant = self.plant
        plat = plant._platform(t)
        self._ffill(x, plat)
        self.pack_ft(self.af_ft, 0, *plat[2], *xd[self.sv])
        plant.emulator_step(t, plant._mount_wrench6(self.qf, self.vf, self.af_ft, xd[self.iP]))

    def full(self, x, t, tau_s, fs, v0, caught):
        # _loads inlined, the platform motion looked up once for the kinematics and the bias
        c = self.c2
        if c[0] is not tau_s or c[1] is not fs:
            c = self.c2 = (tau_s, fs, [a - b for a, b in zip(tau_s, fs.coulomb_f, strict=True)])
        tau = [a - b * w for a, b, w in zip(c[2], self.visc, x[self.sv], strict=False)]
        plat = self.plant._platform(t)
        F, gap = 0.0, None
        if v0 is not None or not caught:
            delta, ddelta, Jn = self._gap_jn(x, t, plat)
            if v0 is not None and delta > 0.0:
                F = self.k * delta**self.p * (1.0 + self.d * ddelta / v0)
                if F > 0.0:
                    tau = [a + j * F for a, j in zip(tau, Jn, strict=True)]
                else:
                    F = 0.0
            gap = (delta, ddelta)
        lam, a = self._constrained(x, t, tau, fs, True, plat)
        return self._xd(x, a, F, caught), lam, gap

    def holding(self, x, t, tau_s, fs, v0):
        tau, _, _ = self._loads(x, t, tau_s, fs, v0, False)
        return self._constrained(x, t, tau, fs, True)[0]


class ArrayKernel:
    """Any plant through its own array methods (the ideal coupling: the reference mode of
    the flexible base, not a fast path): the float lists go in as arrays, come out as lists."""

    def __init__(self, plant):
        self.plant = plant
        self.nv, self.size = plant.nv, plant.size
        self.tau_arr = (None, None)

    def _tau(self, tau):
        c = self.tau_arr
        if c[0] is not tau:
            c = self.tau_arr = (tau, np.array(tau, dtype=float))
        return c[1]

    def servo(self, tau_arm):
        return tuple(self.plant.servo(np.asarray(tau_arm, dtype=float)).tolist())

    def stage(self, x, t, tau_s, fs, v0, caught):
        return self.plant.rhs(np.array(x), self._tau(tau_s), fs, v0, caught, t).tolist()

    def full(self, x, t, tau_s, fs, v0, caught):
        xd, lam, gap = self.plant.evaluate(np.array(x), self._tau(tau_s), fs, v0, caught, t)
        return xd.tolist(), np.asarray(lam).tolist(), (None if gap is None else (float(gap[0]), float(gap[1])))

    def holding(self, x, t, tau_s, fs, v0):
        return np.asarray(self.plant.holding(np.array(x), self._tau(tau_s), fs, v0, t)[0]).tolist()

    def gap(self, x, t=0.0):
        self.plant._t = t
        d, dd, _ = self.plant.gap(np.array(x))
        return d, dd
