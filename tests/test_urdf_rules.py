"""A leg's joints and bodies read from a small URDF written here
(:func:`eigentwist.description.urdf.urdf_leg`), against the URDF format's own meaning: a joint's
``origin`` (xyz, then roll-pitch-yaw about fixed x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll)) places it
in its parent's frame, its ``axis`` is in its own frame, a link's ``inertial`` is given at its
centre of mass (parallel-axis theorem to the joint's origin), a fixed joint's child is merged into
its parent. No derivation: the leg's fields are compared as numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

pytest.importorskip("pinocchio")

from eigentwist.description.serial import Joint  # noqa: E402
from eigentwist.description.urdf import urdf_leg  # noqa: E402
from eigentwist.errors import DescriptionError  # noqa: E402

LIMIT = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'


def rpy(r, p, y):
    cr, sr, cp, spp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, spp], [0, 1, 0], [-spp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def joint(name, kind, parent, child, axis, xyz="0 0 0", rpy_="0 0 0"):
    limit = LIMIT if kind in ("revolute", "prismatic") else ""
    ax = f'<axis xyz="{axis}"/>' if axis else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy_}"/>{ax}{limit}</joint>'
    )


def link(name, mass=None, com="0 0 0", diag=(0, 0, 0)):
    if mass is None:
        return f'<link name="{name}"/>'
    return (
        f'<link name="{name}"><inertial><origin xyz="{com}"/><mass value="{mass}"/>'
        f'<inertia ixx="{diag[0]}" iyy="{diag[1]}" izz="{diag[2]}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )


#: base -(j1: revolute about z, placed and turned)- arm -(j2: continuous about x)- fore
#: -(j3: prismatic along y)- slide -(j4: revolute about an unaligned axis)- hand -(fixed)- tip
CHAIN = [
    link("base"),
    link("arm", 2.0, "0.1 0 0", (0.01, 0.02, 0.03)),
    link("fore"),
    link("slide", 0.5, "0 0.2 0.1", (0.001, 0.002, 0.003)),
    link("hand", 1.5),
    link("tip", 0.25, "0 0 0.1"),
    joint("j1", "revolute", "base", "arm", "0 0 1", "0.1 0.2 0.3", "0.3 -0.2 0.5"),
    joint("j2", "continuous", "arm", "fore", "1 0 0", "0.4 0 0"),
    joint("j3", "prismatic", "fore", "slide", "0 1 0", "0 0.25 0", "0 0 1.5707963267948966"),
    joint("j4", "revolute", "slide", "hand", "0.6 0.8 0", "0 0 0.1"),
    joint("j5", "fixed", "hand", "tip", None, "0.05 0 0.02", "0 0.4 0"),
]


def urdf(parts=CHAIN):
    return '<robot name="arm">' + "".join(parts) + "</robot>"


def numbers(m):
    return np.array(sp.Matrix(m).evalf(), dtype=float)


def leg_of(text=None, **kw):
    args = dict(actuated="j3", attachment=(0.1, 0.2, 0.3), reference=(0.1, 0.2, 0.3, 0.4))
    args.update(kw)
    return urdf_leg(urdf() if text is None else text, "leg 1", **args)


def test_joints_in_chain_order_placed_in_their_parents():
    R0 = rpy(0.0, 0.0, np.pi / 2)
    p0 = np.array([1.0, -2.0, 0.5])
    leg = leg_of(base_origin=tuple(p0), base_rotation=R0.tolist())
    kinds = [j.kind for j in leg.joints]
    assert kinds == ["R", "R", "P", "R", "S"] and [j.name for j in leg.joints[:4]] == ["j1", "j2", "j3", "j4"]
    assert [j.actuated for j in leg.joints] == [False, False, True, False, False]
    assert [j.axes for j in leg.joints[:4]] == [((0, 0, 1),), ((1, 0, 0),), ((0, 1, 0),), ((0.6, 0.8, 0.0),)]
    # the first joint: its URDF placement, then the root link's in the base frame
    assert np.allclose(numbers(leg.joints[0].origin).ravel(), p0 + R0 @ [0.1, 0.2, 0.3], atol=1e-15)
    assert np.allclose(numbers(leg.joints[0].rotation), R0 @ rpy(0.3, -0.2, 0.5), atol=1e-15)
    # the others: as the URDF places them
    assert np.allclose(numbers(leg.joints[1].origin).ravel(), [0.4, 0, 0]) and np.allclose(
        numbers(leg.joints[1].rotation), np.eye(3)
    )
    assert np.allclose(numbers(leg.joints[2].rotation), rpy(0, 0, np.pi / 2), atol=1e-15)
    assert np.allclose(numbers(leg.joints[3].origin).ravel(), [0, 0, 0.1])
    assert all(isinstance(v, sp.Float) for v in leg.joints[2].origin)
    assert leg.reference == (0.1, 0.2, 0.3, 0.4) and leg.platform_body == "platform" and leg.stiffness is None


def test_without_a_base_placement_the_root_is_the_base_frame():
    leg = leg_of()
    assert np.allclose(numbers(leg.joints[0].origin).ravel(), [0.1, 0.2, 0.3])
    assert np.allclose(numbers(leg.joints[0].rotation), rpy(0.3, -0.2, 0.5), atol=1e-15)
    assert numbers(leg.joints[0].rotation).shape == (3, 3)


def spatial(m, c, I_c):
    """6x6 [[I_o, m [c]x], [-m [c]x, m 1]] with I_o = I_c + m (|c|^2 1 - c c^T)."""
    c = np.asarray(c, dtype=float)
    cx = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    I_o = np.asarray(I_c) + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.block([[I_o, m * cx], [-m * cx, m * np.eye(3)]])


def test_bodies_on_the_joints_that_carry_them():
    leg = leg_of()
    assert [(b.name, b.after) for b in leg.bodies] == [("arm", 1), ("slide", 3), ("hand", 4)]  # fore: no mass
    assert np.allclose(numbers(leg.bodies[0].inertia), spatial(2.0, [0.1, 0, 0], np.diag([0.01, 0.02, 0.03])))
    assert np.allclose(numbers(leg.bodies[1].inertia), spatial(0.5, [0, 0.2, 0.1], np.diag([0.001, 0.002, 0.003])))
    # hand and tip merged: 1.75 kg, the tip's centre 0.1 m along its z, which is turned by 0.4 rad about y
    c_tip = np.array([0.05, 0, 0.02]) + rpy(0, 0.4, 0) @ [0, 0, 0.1]
    c = 0.25 * c_tip / 1.75
    I_c = 1.5 * (c @ c * np.eye(3) - np.outer(c, c)) + 0.25 * (
        (c_tip - c) @ (c_tip - c) * np.eye(3) - np.outer(c_tip - c, c_tip - c)
    )
    assert np.allclose(numbers(leg.bodies[2].inertia), spatial(1.75, c, I_c), atol=1e-14)


def test_the_chain_end():
    """The platform's spherical joint at the end link's origin (in the last joint's frame), or at
    the last joint's own origin; a rigid end moves the end link's attachment onto the last joint."""
    leg = leg_of(end="tip")
    s = leg.joints[4]
    assert s.kind == "S" and s.name == "tip spherical joint" and not s.actuated
    assert np.allclose(numbers(s.origin).ravel(), [0.05, 0, 0.02]) and np.allclose(numbers(s.rotation), rpy(0, 0.4, 0))
    s = leg_of().joints[4]
    assert (
        s.name == "j4 spherical joint"
        and np.allclose(numbers(s.origin).ravel(), 0)
        and np.allclose(numbers(s.rotation), np.eye(3))
    )
    Ra = rpy(0.1, 0.2, 0.3)
    rigid = leg_of(end="tip", platform_joint=None, attachment_rotation=Ra.tolist(), reference=(0.1, 0.2, 0.3, 0.4))
    assert [j.kind for j in rigid.joints] == ["R", "R", "P", "R"]
    Rt, pt = rpy(0, 0.4, 0), np.array([0.05, 0, 0.02])
    # the platform sees the last joint's frame at attachment - Ra Rt^T pt, turned Ra Rt^T
    assert np.allclose(numbers(rigid.attachment).ravel(), np.array([0.1, 0.2, 0.3]) - Ra @ Rt.T @ pt)
    assert np.allclose(numbers(rigid.attachment_rotation), Ra @ Rt.T)
    plain = leg_of(end="tip", platform_joint=None)  # the platform's axes where none is given
    assert np.allclose(numbers(plain.attachment_rotation), Rt.T)
    assert np.allclose(numbers(plain.attachment).ravel(), np.array([0.1, 0.2, 0.3]) - Rt.T @ pt)
    no_end = leg_of(platform_joint=None)
    assert np.allclose(numbers(no_end.attachment).ravel(), [0.1, 0.2, 0.3]) and np.allclose(
        numbers(no_end.attachment_rotation), np.eye(3)
    )


def test_what_the_description_adds_passes_through():
    virtual = (Joint("virtual", axes=((0, 0, 1),)),)
    leg = leg_of(
        actuated=None,
        virtual=virtual,
        platform_body="arm body",
        stiffness=1234.0,
        end="tip",
        platform_joint=None,
        attachment_rotation=np.eye(3).tolist(),
    )
    assert not any(j.actuated for j in leg.joints) and leg.joints[-1].kind == "virtual"
    assert leg.platform_body == "arm body" and leg.stiffness == 1234.0 and leg.name == "leg 1"
    assert all(isinstance(v, sp.Basic) or isinstance(v, float) for v in leg.attachment)


def test_a_file_path_or_the_xml_text(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(urdf())
    assert [j.name for j in leg_of(str(path)).joints[:4]] == ["j1", "j2", "j3", "j4"]
    assert [j.name for j in leg_of(path).joints[:4]] == ["j1", "j2", "j3", "j4"]
    assert len(leg_of("  \n" + urdf()).joints) == 5  # XML text after blank space
    with pytest.raises(FileNotFoundError) as err:
        leg_of(str(tmp_path / "none.urdf"))
    assert str(err.value) == f"URDF file {str(tmp_path / 'none.urdf')!r} not found: expected a path or the XML text"


@pytest.mark.parametrize(
    "axis, kind, want",
    [
        ("0 1 0", "revolute", ("R", (0, 1, 0))),
        ("0 0 1", "continuous", ("R", (0, 0, 1))),
        ("0 1 0", "continuous", ("R", (0, 1, 0))),
        ("1 0 0", "prismatic", ("P", (1, 0, 0))),
        ("0 0 1", "prismatic", ("P", (0, 0, 1))),
        ("0 0.6 0.8", "prismatic", ("P", (0.0, 0.6, 0.8))),
        ("0.8 0 0.6", "continuous", ("R", (0.8, 0.0, 0.6))),
    ],
)
def test_joint_kinds_and_axes(axis, kind, want):
    text = urdf([link("a"), link("b", 1.0), joint("q", kind, "a", "b", axis)])
    leg = urdf_leg(text, "one", actuated="q", attachment=(0, 0, 0), reference=(0.0,))
    assert (leg.joints[0].kind, leg.joints[0].axes[0]) == want


def test_refusals_name_the_problem():
    with pytest.raises(DescriptionError) as err:
        leg_of(urdf([link("a")]))
    assert str(err.value) == "leg 1: the URDF has no moving joint: expected the leg's chain"
    with pytest.raises(DescriptionError) as err:
        leg_of(actuated="j9")
    assert str(err.value) == "leg 1: actuated joint 'j9' is not in the URDF (its joints: j1, j2, j3, j4)"
    planar = urdf(
        [link("a"), link("b", 1.0), '<joint name="f" type="planar"><parent link="a"/><child link="b"/></joint>']
    )
    with pytest.raises(DescriptionError) as err:
        urdf_leg(planar, "leg 2", actuated=None, attachment=(0, 0, 0), reference=())
    assert str(err.value) == (
        "URDF joint 'f' is JointModelPlanar: expected revolute, continuous or prismatic joints (fixed ones are "
        "merged; a U joint is two revolute joints, a spherical one is given by platform_joint)"
    )
    branched = urdf(CHAIN[:-1] + [joint("j5", "revolute", "arm", "tip", "0 0 1")])
    with pytest.raises(DescriptionError) as err:
        leg_of(branched, reference=(0.1, 0.2, 0.3, 0.4, 0.5))
    assert (
        str(err.value) == "leg 1: URDF joint 'j5' hangs on 'j1', not on the joint before it: expected one serial chain"
    )
    for end in ("fore", "nowhere"):
        with pytest.raises(DescriptionError) as err:
            leg_of(end=end)
        assert (
            str(err.value) == f"leg 1: end link {end!r} is not on the chain's last joint 'j4': expected a link after it"
        )
    with pytest.raises(DescriptionError) as err:
        leg_of(platform_joint="U")
    assert str(err.value) == "leg 1: platform_joint 'U': expected 'S' or None (rigid)"


def test_numbers_are_the_files_doubles_bit_for_bit():
    """17 significant digits: a double such as 0.1 + 0.2 = 0.30000000000000004 is kept as it is."""
    x = 0.1 + 0.2
    text = urdf([link("a"), link("b", x, f"{x!r} 0 0"), joint("q", "revolute", "a", "b", "0 0 1", f"{x!r} 0 0")])
    leg = urdf_leg(text, "one", actuated="q", attachment=(0, 0, 0), reference=(0.0,))
    assert float(leg.joints[0].origin[0]) == x and float(leg.bodies[0].inertia[5, 5]) == x


def test_without_pinocchio_the_message_says_what_to_install(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pinocchio", None)  # import pinocchio raises ImportError
    with pytest.raises(ImportError) as err:
        leg_of()
    assert str(err.value).startswith('URDF legs need Pinocchio\'s URDF parser: pip install "pin>=3.0" (')
