"""Pinocchio as an independent engine for the tests; never imported by the package.

Each leg of a parallel robot becomes its own kinematic tree in Pinocchio (a
``pin.Model``: revolute, prismatic, universal = two revolute, spherical, and the
parallelogram Pi = R(q3) then R(-q3) about parallel axes, with every rod that swings with
q3 on its own revolute branch R(q3) about its own pivot), and the platform its own free
body (a free-flyer model). At a platform pose the harness

1. solves each leg's loop closure itself (damped Newton on Pinocchio's forward
   kinematics, from the reference configuration: the leg's end link, carrying the
   platform's origin, must sit at the platform's pose);
2. takes each tree's mass matrix (``pin.crba``) and the leg's velocity map: the joint
   rates as a linear function of the platform twist, ``u = G t`` with ``G`` the inverse
   of the end link's frame Jacobian (``pin.getFrameJacobian``, LOCAL_WORLD_ALIGNED at
   the platform origin) over the leg's independent coordinates (a leg with fewer than six
   freedoms lists its twists of restriction as ``virtual`` revolute joints, so the
   Jacobian is 6x6);
3. reduces: ``M = M_platform + sum_legs (P G)^T M_tree (P G)`` (P: the tree's joint rates
   per independent coordinate, -1 for the far axis of a Pi joint) and
   ``K = sum_legs J_e^T (J_e C_s J_e^T + diag(c_e))^-1 J_e`` with ``J_e`` the rows of G of
   the elastic joints (the actuated one, compliance ``c_act``; the virtual ones,
   ``c_virtual``) and ``C_s`` the body compliances moved to the platform origin with
   Pinocchio's SE3 action. Both 6x6 at the platform origin, base axes, twists ``[omega; v]``
   (Pinocchio's order is [v; omega]: converted here), then ``E^T M E``, ``E^T K E`` over a
   basis E (6 x f) of the platform's freedoms.

The robot enters as numbers (:class:`PinRobot`: joints' axes and locations, bodies'
inertias and frames, all in the world frame at a reference configuration), so a robot
written any way can be checked; :func:`from_description` reads an eigentwist description
(``RobotDescription`` or ``ChainRobot``) at its reference pose. Entry point and how to
add a robot: ``tests/PINOCCHIO.md`` (see
:func:`compare`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
import sympy as sp

__all__ = [
    "PinJoint",
    "PinBody",
    "PinFrame",
    "PinLeg",
    "PinRobot",
    "PinocchioRobot",
    "from_description",
    "eigen_frequencies",
    "rotation_vector_matrix",
]


# --------------------------------------------------------------------------- description (numbers)
@dataclass
class PinJoint:
    """One joint in the world frame at the reference configuration.

    kind : "R", "P", "U", "S", "Pi", "virtual" (a twist of restriction: a revolute joint
        that carries nothing, rate zero at reachable poses).
    axes : unit axes (R, P, virtual: 1; U: 2; S: ignored; Pi: the translation direction).
    location : a point on the axes (m); for Pi the near pivot of the rods' centre line.
    swing : Pi only, ``(n, length)``: the rods' pivot axis (unit) and their length (m);
        the far pivot is ``location + length * (t x n)`` (t: the translation direction),
        and the Pi coordinate is the swing angle q3 (rad).
    """

    kind: str
    axes: tuple = ()
    location: np.ndarray | None = None
    actuated: bool = False
    swing: tuple | None = None


@dataclass
class PinBody:
    """A rigid body: 6x6 spatial inertia ``[omega; v]`` in its frame (axes ``rotation``,
    columns in world axes; ``origin`` m), carried by the link after chain joint ``joint``
    (0-based); with ``pivot`` (a point, m) it hangs on the swinging part of that joint (a
    Pi joint): its own revolute branch R(q3) about the Pi joint's swing axis through
    ``pivot``. ``riding``: the paper's fictitious rod (Eqs. 26-29) on a Pi joint: it moves
    with the far link (a translation), but sits where the rods' centre line is at the
    current configuration (its frame follows the swing, its velocity does not).
    """

    name: str
    joint: int
    inertia: np.ndarray
    rotation: np.ndarray
    origin: np.ndarray
    pivot: np.ndarray | None = None
    riding: bool = False


@dataclass
class PinFrame:
    """A frame for a body compliance: carried like a :class:`PinBody` (``joint`` = -1: the
    platform, i.e. the leg's end link)."""

    name: str
    joint: int
    rotation: np.ndarray
    origin: np.ndarray
    pivot: np.ndarray | None = None


@dataclass
class PinLeg:
    name: str
    joints: list
    bodies: list = field(default_factory=list)
    frames: list = field(default_factory=list)


@dataclass
class PinRobot:
    """Legs, the platform's 6x6 inertia at its origin in platform axes (``[omega; v]``),
    and the platform's reference pose (position m, rotation 3x3) at which the legs' numbers
    are given."""

    legs: list
    platform_inertia: np.ndarray
    position: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


# --------------------------------------------------------------------------- helpers
SWAP = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])  # [v; w] <-> [w; v]


def rotation_vector_matrix(rv) -> np.ndarray:
    """Rotation matrix of a rotation vector (rad), Pinocchio's exp3."""
    return pin.exp3(np.asarray(rv, dtype=float))


def _inertia(M6: np.ndarray) -> pin.Inertia:
    """pin.Inertia of a 6x6 [omega; v] spatial inertia in its own frame."""
    m = M6[3, 3]
    mc = M6[:3, 3:]  # m [c]x
    c = np.array([mc[2, 1], mc[0, 2], mc[1, 0]]) / m if m > 0 else np.zeros(3)
    I_com = M6[:3, :3] - m * (c @ c * np.eye(3) - np.outer(c, c))
    return pin.Inertia(m, c, 0.5 * (I_com + I_com.T))


def _sym(M):
    return np.triu(M) + np.triu(M, 1).T


def eigen_frequencies(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Natural frequencies (Hz, ascending) of ``K x = (2 pi f)^2 M x``."""
    from scipy.linalg import eigh

    lam = eigh(K, M, eigvals_only=True)
    return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)


# --------------------------------------------------------------------------- the engine
class _LegTree:
    """One leg as a Pinocchio model; the link placements at q = 0 are the reference."""

    def __init__(self, leg: PinLeg, platform_origin: np.ndarray):
        self.leg = leg
        model = pin.Model()
        loc = {0: np.zeros(3)}  # pin joint id -> world location at reference
        self.cols = []  # per pin joint: list of (independent index, factor)
        last_of = []  # chain joint -> pin joint id carrying the link after it
        swing_of = {}  # chain joint (Pi) -> (parent id, axis, independent index)
        self.actuated, self.virtual = [], []
        parent, n_u = 0, 0

        def add(jm, location, name, cols):
            nonlocal parent
            location = np.asarray(location, dtype=float)
            jid = model.addJoint(parent, jm, pin.SE3(np.eye(3), location - loc[parent]), name)
            loc[jid] = location
            self.cols.append(cols)
            parent = jid
            return jid

        for j, joint in enumerate(leg.joints):
            here = loc[parent] if joint.location is None else np.asarray(joint.location, dtype=float)
            if joint.kind in ("R", "virtual"):
                if joint.actuated:
                    self.actuated.append(n_u)
                if joint.kind == "virtual":
                    self.virtual.append(n_u)
                add(pin.JointModelRevoluteUnaligned(*np.asarray(joint.axes[0], float)), here, f"j{j}", [(n_u, 1.0)])
                n_u += 1
            elif joint.kind == "P":
                if joint.actuated:
                    self.actuated.append(n_u)
                add(pin.JointModelPrismaticUnaligned(*np.asarray(joint.axes[0], float)), here, f"j{j}", [(n_u, 1.0)])
                n_u += 1
            elif joint.kind == "U":
                for k, axis in enumerate(joint.axes):
                    add(pin.JointModelRevoluteUnaligned(*np.asarray(axis, float)), here, f"j{j}_{k}", [(n_u, 1.0)])
                    n_u += 1
            elif joint.kind == "S":
                add(pin.JointModelSpherical(), here, f"j{j}", [(n_u + k, 1.0) for k in range(3)])
                n_u += 3
            elif joint.kind == "Pi":
                n, length = np.asarray(joint.swing[0], float), float(joint.swing[1])
                t = np.asarray(joint.axes[0], float)
                swing_of[j] = (parent, n, n_u)
                add(pin.JointModelRevoluteUnaligned(*n), here, f"j{j}_near", [(n_u, 1.0)])
                add(pin.JointModelRevoluteUnaligned(*n), here + length * np.cross(t, n), f"j{j}_far", [(n_u, -1.0)])
                n_u += 1
            else:
                raise ValueError(f"{leg.name}: joint kind {joint.kind!r}: expected R, P, U, S, Pi or virtual")
            last_of.append(parent)
        self.n_u = n_u
        if n_u != 6:
            raise ValueError(f"{leg.name}: {n_u} independent joint rates; expected 6 (virtual joints included)")
        end = parent

        def carrier(j, pivot, name):
            """(pin joint id, its world location at reference) carrying a body/frame."""
            if pivot is None:
                jid = end if j == -1 else last_of[j]
                return jid, loc[jid]
            if j not in swing_of:
                raise ValueError(f"{leg.name}: {name} has a pivot but joint {j} is not a Pi joint")
            p_id, n, k = swing_of[j]
            jm = pin.JointModelRevoluteUnaligned(*n)
            pivot = np.asarray(pivot, float)
            jid = model.addJoint(p_id, jm, pin.SE3(np.eye(3), pivot - loc[p_id]), f"{name}_swing")
            loc[jid] = pivot
            self.cols.append([(k, 1.0)])
            return jid, pivot

        self.riding = []  # (frame id placing it, carrier joint id, inertia)
        for b in leg.bodies:
            if b.riding:
                sid, at = carrier(b.joint, leg.joints[b.joint].location, b.name)
                fid = model.addFrame(
                    pin.Frame(
                        f"{b.name}_place",
                        sid,
                        pin.SE3(np.asarray(b.rotation, float), np.asarray(b.origin, float) - at),
                        pin.FrameType.OP_FRAME,
                    )
                )
                self.riding.append((fid, last_of[b.joint], np.asarray(b.inertia, float)))
                continue
            jid, at = carrier(b.joint, b.pivot, b.name)
            model.appendBodyToJoint(
                jid,
                _inertia(np.asarray(b.inertia, float)),
                pin.SE3(np.asarray(b.rotation, float), np.asarray(b.origin, float) - at),
            )
        self.frame_ids = {}
        for f in leg.frames:
            jid, at = carrier(f.joint, f.pivot, f.name)
            self.frame_ids[f.name] = model.addFrame(
                pin.Frame(
                    f.name,
                    jid,
                    pin.SE3(np.asarray(f.rotation, float), np.asarray(f.origin, float) - at),
                    pin.FrameType.OP_FRAME,
                )
            )
        self.origin_id = model.addFrame(
            pin.Frame("platform_origin", end, pin.SE3(np.eye(3), platform_origin - loc[end]), pin.FrameType.OP_FRAME)
        )
        self.model, self.data = model, model.createData()
        # P: tree joint rates (nv) per independent coordinate (6)
        P = np.zeros((model.nv, n_u))
        for jid, cols in zip(range(1, model.njoints), self.cols):
            idx = model.joints[jid].idx_v
            for k, (u, factor) in enumerate(cols):
                P[idx + k, u] = factor
        self.P = P

    def solve(self, target: pin.SE3, q0=None, tol=1e-13, iterations=60) -> np.ndarray:
        """The tree's configuration whose end link puts the platform origin at ``target``
        (Newton on log6 of the placement error, over the independent coordinates)."""
        model, data = self.model, self.data
        q = pin.neutral(model) if q0 is None else q0.copy()
        for _ in range(iterations):
            pin.framesForwardKinematics(model, data, q)
            err_m = target.actInv(data.oMf[self.origin_id])
            err = pin.log6(err_m).vector
            if np.linalg.norm(err) < tol:
                return q
            J = pin.computeFrameJacobian(model, data, q, self.origin_id, pin.LOCAL) @ self.P
            du = -np.linalg.solve(pin.Jlog6(err_m) @ J, err)
            q = pin.integrate(model, q, self.P @ du)
        raise RuntimeError(f"{self.leg.name}: loop closure did not converge (|error| {np.linalg.norm(err):.3g})")

    def at(self, q) -> dict:
        """Mass matrix, velocity map and frames at configuration ``q``."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        J = SWAP @ pin.getFrameJacobian(model, data, self.origin_id, pin.LOCAL_WORLD_ALIGNED) @ self.P  # [w; v]
        G = np.linalg.inv(J)  # independent rates per platform twist
        M = _sym(pin.crba(model, data, q))
        for fid, jid, I6 in self.riding:
            oMf, oMj = data.oMf[fid], data.oMi[jid]
            Jj = pin.getJointJacobian(model, data, jid, pin.LOCAL_WORLD_ALIGNED)  # [v at the joint; w], world
            v_at = Jj[:3] + np.cross(Jj[3:].T, oMf.translation - oMj.translation).T
            Jb = np.vstack([oMf.rotation.T @ Jj[3:], oMf.rotation.T @ v_at])  # [w; v] in the body frame
            M = M + Jb.T @ I6 @ Jb
        PG = self.P @ G
        return {
            "M": PG.T @ M @ PG,
            "G": G,
            "q": q.copy(),
            "frames": {name: data.oMf[fid].copy() for name, fid in self.frame_ids.items()},
            "origin": data.oMf[self.origin_id].translation.copy(),
        }


class PinocchioRobot:
    """The robot in Pinocchio: :meth:`matrices` at a pose."""

    def __init__(self, robot: PinRobot):
        self.robot = robot
        self.p_ref, self.R_ref = np.asarray(robot.position, float), np.asarray(robot.rotation, float)
        self.legs = [_LegTree(leg, self.p_ref) for leg in robot.legs]
        fm = pin.Model()
        jid = fm.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "platform")
        fm.appendBodyToJoint(jid, _inertia(np.asarray(robot.platform_inertia, float)), pin.SE3.Identity())
        self.platform, self.platform_data = fm, fm.createData()
        self._q = [None] * len(self.legs)

    def configurations(self, position, rotation=None) -> list:
        """Each leg's tree configuration at the platform pose (position m, rotation 3x3),
        Newton from the previous solution (or the reference)."""
        R = np.eye(3) if rotation is None else np.asarray(rotation, float)
        target = pin.SE3(R @ self.R_ref.T, np.asarray(position, float))
        out = []
        for k, leg in enumerate(self.legs):
            try:
                q = leg.solve(target, self._q[k])
            except RuntimeError:
                q = leg.solve(target, None)
            self._q[k] = q
            out.append(q)
        return out

    def platform_mass(self, position, R) -> np.ndarray:
        """The platform's 6x6 inertia at its origin, base axes, ``[omega; v]``, from the
        free-flyer model's ``crba`` (body-local ``[v; omega]``)."""
        q = np.concatenate([position, pin.Quaternion(R).coeffs()])  # the platform's axes are R
        Ml = SWAP @ _sym(pin.crba(self.platform, self.platform_data, q)) @ SWAP
        A = np.kron(np.eye(2), R.T)  # base twist -> platform axes
        return A.T @ Ml @ A

    def matrices(self, position, rotation=None, *, c_act, c_virtual=0.0, compliances=None, stiffness="elastic") -> dict:
        """``M`` and ``K`` (6x6, platform origin, base axes, ``[omega; v]``) at a pose.

        c_act : compliance of each actuated joint (rad/(N m) or m/N; a number or a list
            per leg); c_virtual : of each virtual joint. compliances : ``{frame name:
            f(leg index, state) -> 6x6 local compliance [omega; v]}`` (``state``: the leg's
            configuration and frames). ``stiffness="actuated"`` keeps only the actuated
            joints (K_R, Eq. 14); ``"elastic"`` the actuated and virtual joints with the
            body compliances (K_F, Eqs. 13, 40-43).
        """
        position = np.asarray(position, float)
        R = np.eye(3) if rotation is None else np.asarray(rotation, float)
        qs = self.configurations(position, R)
        M = self.platform_mass(position, R)
        K = np.zeros((6, 6))
        states = []
        for i, (leg, q) in enumerate(zip(self.legs, qs)):
            st = leg.at(q)
            states.append(st)
            M += st["M"]
            ca = c_act[i] if np.ndim(c_act) else c_act
            rows_a = st["G"][leg.actuated]
            if stiffness == "actuated":
                K += rows_a.T @ rows_a / ca
                continue
            Je = np.vstack([rows_a, st["G"][leg.virtual]])
            Cs = np.zeros((6, 6))
            for name, law in (compliances or {}).items():
                if name not in st["frames"]:
                    continue
                C_local = law(i, st)
                if C_local is None:
                    continue
                oMf = st["frames"][name]
                Ad = SWAP @ pin.SE3(oMf.rotation, oMf.translation - st["origin"]).action @ SWAP  # local -> origin
                Cs += Ad @ C_local @ Ad.T
            Cq = Je @ Cs @ Je.T + np.diag([ca] * len(leg.actuated) + [c_virtual] * len(leg.virtual))
            K += Je.T @ np.linalg.solve(Cq, Je)
        return {"M": M, "K": K, "q": qs, "states": states}


# --------------------------------------------------------------------------- from an eigentwist description
class _Stub:
    """The program interface the closed forms write to, keeping plain expressions."""

    def let(self, name, e):
        return e

    def let_matrix(self, name, m):
        return m


def from_description(robot, params: dict, q_ref, pose_ref, *, frames=(), swing_bodies=()) -> PinRobot:
    """A :class:`PinRobot` from an eigentwist description at its reference pose.

    robot : a ``RobotDescription`` or ``ChainRobot``; params : parameter values by name;
    q_ref : (legs, k) joint coordinates at the reference pose (eigentwist's IK, only to
    place the joints once); pose_ref : the reference pose in the robot's coordinates
    (x, y, z m; rot_x, rot_y, rot_z rad for a 6-DoF robot). frames : ``(name, joint,
    pivot name or None)`` of the leg frames (``leg.frames``) a compliance acts in, carried
    by chain joint ``joint`` (-1: the platform). swing_bodies : ``(name, joint, pivot name,
    inertia 6x6 or callable(params) -> 6x6, rotation names, origin name)`` of extra bodies
    hanging on a Pi joint's swing.
    """
    from eigentwist.description import sym

    pose_space = robot.pose_space
    pose_ref = np.asarray(pose_ref, float)
    position = pose_ref[:3]
    R = rotation_vector_matrix(pose_ref[3:6]) if len(pose_ref) == 6 else np.eye(3)
    subs = {sym(k): v for k, v in params.items()}
    subs.update({s: float(v) for s, v in zip(pose_space.inputs[:3], position)})
    subs.update(
        {
            pose_space.inputs[3 + 3 * i + j]: float(R[i, j])
            for i in range(3)
            for j in range(3)
            if len(pose_space.inputs) > 3
        }
    )
    num = lambda e: np.array(sp.Matrix(e).xreplace(subs).evalf(30), dtype=float).ravel()  # noqa: E731
    origin = num(pose_space.origin)
    point = lambda e: num(e) - origin + position  # noqa: E731
    legs = []
    for leg, q in zip(robot.legs, np.asarray(q_ref, float)):
        g = leg.kinematics.geometry(_Stub(), leg, tuple(sp.Float(v, 30) for v in q), pose_space, "ref")
        vec = lambda v: num(g[v] if isinstance(v, str) else sp.Matrix(v))  # noqa: E731
        pt = lambda v: point(g[v] if isinstance(v, str) else sp.Matrix(v))  # noqa: E731
        scal = lambda v: float(sp.sympify(g[v] if isinstance(v, str) else v).xreplace(subs))  # noqa: E731
        joints = []
        for jt in leg.joints:
            axes = tuple(vec(a) for a in jt.axes) if jt.axes else tuple(np.eye(3))
            swing = getattr(jt, "swing", None) or None
            joints.append(
                PinJoint(
                    jt.kind,
                    axes,
                    None if jt.location is None else pt(jt.location),
                    jt.actuated,
                    None if swing is None else (vec(swing[0]), scal(swing[1])),
                )
            )
        rot = lambda names: np.column_stack([vec(a) for a in names])  # noqa: E731
        # a body after a Pi joint without a pivot is the paper's fictitious rod: it rides
        bodies = [
            PinBody(
                b.name,
                b.after - 1,
                num(b.inertia).reshape(6, 6),
                rot(b.rotation),
                pt(b.origin),
                None if getattr(b, "pivot", None) is None else pt(b.pivot),
                riding=leg.joints[b.after - 1].kind == "Pi" and getattr(b, "pivot", None) is None,
            )
            for b in leg.bodies
        ]
        for name, joint, pivot, inertia, axes, org in swing_bodies:
            I6 = inertia(params) if callable(inertia) else inertia
            bodies.append(PinBody(name, joint, np.asarray(I6, float), rot(axes), pt(org), pt(pivot)))
        fr = {n: (axes, org) for n, axes, org in leg.frames}
        pframes = [PinFrame(n, j, rot(fr[n][0]), pt(fr[n][1]), None if pv is None else pt(pv)) for n, j, pv in frames]
        legs.append(PinLeg(leg.name, joints, bodies, pframes))
    platform = np.array(robot.platform_inertia.xreplace(subs).evalf(30), dtype=float)
    return PinRobot(legs, platform, position, R)
