"""Every limitation kind's compiled rows against the oracle (``oracles/limitations.py``):
equal to 1e-12 on 100 % of random states of every robot, zones of every kind (penetrated boxes
included) and a moving human; every registered kind dispatches; an unknown kind is refused;
the rows' gradients and the human's rate against finite differences."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from cobotsafety.arm.controller import ArmController
from cobotsafety.arm.limitations import (BoxZone, CapsuleZone, HalfSpaceZone, HumanLimitation, JointPositionLimits,
                                         ReachLimits, SphereZone, TablePlane)
from cobotsafety.arm.limitations import human as human_kind
from cobotsafety.arm.limitations.registry import KINDS, UnsupportedLimitationError, pack_scene
from cobotsafety.arm.limitations.rows import kind_count, kind_distances, kind_rows
from cobotsafety.arm.robots import ROBOTS
from cobotsafety.errors import CobotSafetyError
from compiled_arm import compiled_distances, compiled_kinematics, compiled_pulls, compiled_rows, human_tuple, robot
from oracles import limitations as oracle
from oracles.geometry import capsule_pair, segment_box
from oracles.kinematics import Kinematics, random_configuration

ROBOT_NAMES = list(ROBOTS)
STATES = 40


def _point(x) -> tuple[float, float, float]:
    return tuple(float(v) for v in x)


def random_scene(model, kin: Kinematics, rng: np.random.Generator):
    """One limitation of every kind placed on the arm (so that rows are active), two boxes the
    arm penetrates (one through a capsule, one around a whole capsule) and a moving human of
    one to five capsules. Returns ``(limitations, human (oracle.Human), ahead_s, activation_m)``."""
    n_caps = len(model.capsules)

    def on_arm(spread):
        c = int(rng.integers(0, n_caps))
        return kin.p0[c] + rng.uniform() * (kin.p1[c] - kin.p0[c]) + rng.normal(size=3) * spread

    def skip():
        return int(rng.integers(0, n_caps + 1))

    c = int(rng.integers(1, n_caps))
    middle, half_axis = 0.5 * (kin.p0[c] + kin.p1[c]), 0.5 * np.abs(kin.p1[c] - kin.p0[c])
    r = float(np.linalg.norm(kin.p_ee - kin.p0[0]))
    limitations = [
        JointPositionLimits(),
        ReachLimits(_point(kin.p0[0] + rng.normal(size=3) * 0.05), r * rng.uniform(0.5, 1.1), r * rng.uniform(0.9, 1.5)),
        TablePlane(float(rng.uniform(-0.1, 0.6)), skip_capsules=skip()),
        SphereZone("sphere", _point(on_arm(0.15)), float(rng.uniform(0.02, 0.2)), skip_capsules=skip()),
        CapsuleZone("capsule", _point(on_arm(0.15)), _point(on_arm(0.15)), float(rng.uniform(0.01, 0.15)),
                    skip_capsules=skip()),
        HalfSpaceZone("wall", _point(on_arm(0.1)), _point(rng.normal(size=3)), skip_capsules=skip()),
        BoxZone("box", _point(on_arm(0.15)), _point(rng.uniform(0.02, 0.2, 3)), skip_capsules=skip()),
        BoxZone("box through", _point(on_arm(0.01)), _point(rng.uniform(0.01, 0.06, 3)), skip_capsules=skip()),
        BoxZone("box around", _point(middle), _point(half_axis + rng.uniform(0.0, 0.05, 3)), skip_capsules=0),
    ]
    h = int(rng.integers(1, 6))
    p0 = np.array([on_arm(0.25) for _ in range(h)])
    p1 = p0 + rng.normal(size=(h, 3)) * 0.2 * rng.integers(0, 2, size=(h, 1))  # some spheres
    human = oracle.Human(p0, p1, rng.uniform(0.03, 0.2, h), rng.normal(size=(h, 3)) * 0.5, rng.normal(size=(h, 3)) * 0.5)
    limitations.insert(int(rng.integers(0, len(limitations) + 1)),
                       HumanLimitation(critical_m=float(rng.uniform(0.0, 0.3)), activation_m=float(rng.uniform(0.1, 1.5)),
                                       skip_capsules=skip()))
    return limitations, human, float(rng.uniform(0.0, 0.05)), float(rng.uniform(0.02, 0.6))


def test_the_oracles_own_geometry_against_brute_force_sampling():
    """The oracle's segment-box and capsule distances against a dense sampling of the segment
    (a third, independent computation): never above the sampled minimum, and within the
    sampling's resolution of it; inside a box too."""
    rng = np.random.default_rng(7)
    s = np.linspace(0.0, 1.0, 4001)[:, None]
    for _ in range(200):
        c, h = rng.normal(size=3) * 0.2, rng.uniform(0.02, 0.3, 3)
        a, b = c + rng.normal(size=3) * 0.3, c + rng.normal(size=3) * 0.3
        step = np.linalg.norm(b - a) / 4000
        q = np.abs(a + s * (b - a) - c) - h  # the box's signed distance at every sample
        sampled = (np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)).min()
        d, _, _ = segment_box(a, b, c, h)
        assert sampled - step <= d <= sampled + 1e-12
        b0, b1 = rng.normal(size=3), rng.normal(size=3)
        dc, _, _ = capsule_pair(a, b, 0.1, b0, b1, 0.05)
        grid = a + s * (b - a)
        t = np.clip((grid - b0) @ (b1 - b0) / ((b1 - b0) @ (b1 - b0)), 0, 1)
        sampled = np.linalg.norm(grid - (b0 + t[:, None] * (b1 - b0)), axis=1).min() - 0.15
        assert sampled - step <= dc <= sampled + 1e-12


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_every_kinds_rows_equal_the_oracle_on_every_random_state(name):
    model = robot(name)
    rng = np.random.default_rng(1000 + ROBOT_NAMES.index(name))
    seen_kinds, penetrated = set(), 0
    for _ in range(STATES):
        q = random_configuration(model.model, rng)
        kin_o = Kinematics(model, q)
        limitations, human, ahead_s, activation = random_scene(model, kin_o, rng)
        pack = pack_scene(limitations, model)
        kin = compiled_kinematics(model, q)[0]
        hum = human_tuple(human.p0, human.p1, human.radius, human.v0, human.v1, ahead_s)
        dist, A, rate, angular, tag, before = compiled_rows(pack, model, kin, hum, activation)
        expected, measured = oracle.rows(limitations, kin_o, human.ahead(ahead_s), activation)
        assert [tuple(t) for t in tag] == [row.tag for row in expected]
        np.testing.assert_allclose(dist, [row.d for row in expected], rtol=0, atol=1e-12)
        np.testing.assert_allclose(A, np.array([row.a for row in expected]).reshape(-1, model.nv), rtol=0, atol=1e-12)
        np.testing.assert_allclose(rate, [row.rate for row in expected], rtol=0, atol=1e-12)
        assert angular.tolist() == [row.angular for row in expected]
        np.testing.assert_allclose(before, measured, rtol=0, atol=1e-12)
        for lim, got in zip(limitations, compiled_distances(pack, model, kin, hum), strict=True):
            np.testing.assert_allclose(got, oracle.distances(lim, kin_o, human.ahead(ahead_s)), rtol=0, atol=1e-12)
        seen_kinds |= {type(limitations[t[0]]) for t in tag}
        box_rows = [i for i, t in enumerate(tag) if isinstance(limitations[t[0]], BoxZone)]
        penetrated += sum(dist[i] < -kin_o.radius[tag[i][1]] for i in box_rows)  # the axis inside the box
    assert seen_kinds == set(KINDS)  # every kind had active rows
    assert penetrated >= STATES // 2  # the box's inside case was exercised


def sample_limitations():
    """One instance of every registered kind (a kind added to the registry without one here
    fails ``test_every_registered_kind_dispatches``)."""
    return {JointPositionLimits: JointPositionLimits(), ReachLimits: ReachLimits((0.0, 0.0, 0.3), 0.2, 0.8),
            TablePlane: TablePlane(0.0), SphereZone: SphereZone("s", (0.4, 0.0, 0.4), 0.1),
            CapsuleZone: CapsuleZone("c", (0.3, -0.2, 0.3), (0.3, 0.2, 0.3), 0.05),
            HalfSpaceZone: HalfSpaceZone("w", (0.6, 0.0, 0.0), (1.0, 0.0, 0.0)),
            BoxZone: BoxZone("b", (0.4, 0.0, 0.3), (0.1, 0.1, 0.1)), HumanLimitation: HumanLimitation()}


def test_every_registered_kind_dispatches_and_an_unknown_code_does_not():
    model = robot("panda")
    samples = sample_limitations()
    assert set(samples) == set(KINDS)
    kin = compiled_kinematics(model, model.home_q)[0]
    hum = human_tuple([[0.5, 0.0, 0.5]], [[0.5, 0.0, 1.0]], [0.1], np.zeros((1, 3)), np.zeros((1, 3)))
    n_caps, L = len(model.capsules), len(model.limited)
    for kind_type, module in KINDS.items():
        real, skip = module.pack(samples[kind_type], model)
        size = kind_count(module.KIND, real, skip, n_caps, L, 1)
        assert size > 0, kind_type
        out = (np.empty(size), np.empty((size, model.nv)), np.empty(size), np.empty(size, dtype=np.bool_),
               np.empty((size, 3), dtype=np.int64), np.zeros(size), np.zeros(size))
        before = np.full(size, np.nan)
        m = kind_rows(module.KIND, real, skip, 0, kin, hum, np.inf, out, 0, before)
        if kind_type in (BoxZone, CapsuleZone, SphereZone):  # each capsule's closest point, its ends unless one is
            closest = out[4][:m][out[4][:m, 2] == 0, 1]
            assert sorted(closest) == list(range(1, n_caps)) and size // 3 * 2 <= m <= size
        else:
            assert m == size, kind_type  # every distance is a row at an infinite activation distance
        assert np.all(np.isfinite(before))
        values = np.full(size, np.nan)
        kind_distances(module.KIND, real, skip, kin, hum, values)
        assert np.all(np.isfinite(values))
    unknown = max(m.KIND for m in KINDS.values()) + 1
    assert kind_count(unknown, np.zeros(12), 0, n_caps, L, 1) == -1
    out = (np.empty(1), np.empty((1, model.nv)), np.empty(1), np.empty(1, dtype=np.bool_), np.empty((1, 3), dtype=np.int64),
           np.zeros(1), np.zeros(1))
    assert kind_rows(unknown, np.zeros(12), 0, 0, kin, hum, np.inf, out, 0, np.empty(1)) == -1


def test_the_human_buffer_is_the_five_arrays_end_to_end_in_order():
    """``human_buffer`` (compiled) against numpy's concatenation of the five flattened arrays,
    contiguous or not, for 1 to 6 capsules; ``unpack_human`` gives them back."""
    rng = np.random.default_rng(24)
    for h in range(1, 7):
        wide = rng.standard_normal((h, 6))
        p0, p1 = wide[:, ::2], rng.standard_normal((h, 3))  # (a strided view and a plain array)
        radius, v0, v1 = rng.random(h), rng.standard_normal((3, h)).T, rng.standard_normal((h, 3))
        buffer = human_kind.human_buffer(p0, p1, radius, v0, v1)
        assert np.array_equal(buffer, np.concatenate([a.reshape(-1) for a in (p0, p1, radius, v0, v1)]))
        back = human_kind.unpack_human(buffer, 0.0)
        for got, given in zip(back, (p0, p1, radius, v0, v1)):
            assert np.array_equal(got, given)


class Fence:
    """A limitation nobody registered."""

    name = "fence"


class RoundBox(BoxZone):
    """A subclass of a registered kind is another kind: refused too, never run as a box."""


def test_an_unknown_limitation_is_refused_at_packing_and_at_the_step():
    model = robot("panda")
    for stranger in (Fence(), RoundBox("round", (0.4, 0.0, 0.3), (0.1, 0.1, 0.1))):
        with pytest.raises(UnsupportedLimitationError, match=f"{type(stranger).__name__}.*known kinds: BoxZone"):
            pack_scene([JointPositionLimits(), stranger], model)
    arm = ArmController("panda", zones=[Fence()], reach=False)
    with pytest.raises(UnsupportedLimitationError, match="Fence"):
        arm.step(np.array([0.1, 0.0, 0.0]), 0.002)
    arm = ArmController("panda", zones=[], reach=False)
    arm.step(np.zeros(3), 0.002)
    arm._scene_i[0, 0] = 99  # a code the compiled dispatch does not know
    q = arm.state.q.copy()
    with pytest.raises(CobotSafetyError, match="refused the scene"):
        arm.step(np.array([0.1, 0.0, 0.0]), 0.002)
    np.testing.assert_array_equal(arm.state.q, q)


def test_packing_refuses_bad_scenes_with_a_clear_error():
    model = robot("panda")
    with pytest.raises(ValueError, match="skips 99 capsules"):
        pack_scene([TablePlane(0.0, skip_capsules=99)], model)
    with pytest.raises(ValueError, match="at most one human"):
        pack_scene([HumanLimitation(), HumanLimitation()], model)
    with pytest.raises(ValueError, match="non-finite"):
        pack_scene([SphereZone("s", (np.nan, 0.0, 0.0), 0.1)], model)


@pytest.mark.parametrize("name", ["panda", "kinova", "iiwa"])
def test_row_gradients_and_the_human_rate_match_finite_differences(name):
    """``d(q + eps qdot) - d(q - eps qdot)`` over ``2 eps`` equals ``a . qdot`` for every row
    where the distance is smooth (the closest feature does not switch within +-eps); moving the
    human along its velocity changes ``d`` at ``rate``."""
    model = robot(name)
    rng = np.random.default_rng(2000 + ROBOT_NAMES.index(name))
    eps = 1e-6
    checked = {}
    for _ in range(15):
        q = random_configuration(model.model, rng)
        kin_o = Kinematics(model, q)
        limitations, human, _, _ = random_scene(model, kin_o, rng)
        pack = pack_scene(limitations, model)
        hum = human_tuple(human.p0, human.p1, human.radius, human.v0, human.v1)
        dist, A, rate, _, tag, _ = compiled_rows(pack, model, compiled_kinematics(model, q)[0], hum, np.inf)
        qdot = rng.normal(size=model.nv)

        def by_tag(q_moved, hum_moved):
            d, *_, t, _ = compiled_rows(pack, model, compiled_kinematics(model, q_moved)[0], hum_moved, np.inf)
            return {tuple(k): v for k, v in zip(t, d)}

        plus = by_tag(pin.integrate(model.model, q, eps * qdot), hum)
        minus = by_tag(pin.integrate(model.model, q, -eps * qdot), hum)
        later = by_tag(q, human_tuple(human.p0, human.p1, human.radius, human.v0, human.v1, eps))
        earlier = by_tag(q, human_tuple(human.p0, human.p1, human.radius, human.v0, human.v1, -eps))
        for i, t in enumerate(map(tuple, tag)):
            kind = type(limitations[t[0]]).__name__
            if t in plus and t in minus and abs(plus[t] + minus[t] - 2 * dist[i]) < 1e-9:
                assert A[i] @ qdot == pytest.approx((plus[t] - minus[t]) / (2 * eps), rel=1e-5, abs=1e-6), (kind, t)
                checked[kind] = checked.get(kind, 0) + 1
            if pack.kinds[t[0]] == human_kind.KIND and abs(later[t] + earlier[t] - 2 * dist[i]) < 1e-9:
                assert rate[i] == pytest.approx((later[t] - earlier[t]) / (2 * eps), rel=1e-5, abs=1e-6), t
                checked["rate"] = checked.get("rate", 0) + 1
    assert set(checked) == {m.__name__ for m in KINDS} | {"rate"}, checked


def test_the_extended_reachs_outward_drift_is_the_second_derivative_of_the_radius():
    """A hand moving at constant velocity ``v`` from ``p``: ``d^2/dt^2 |p + v t - c|`` at 0 (a
    central finite difference, an independent oracle) is ``outward_drift``; zero for a radial
    motion, ``|v|^2 / r`` for a tangential one."""
    from cobotsafety.arm.limitations.reach import outward_drift

    rng = np.random.default_rng(47)
    real = np.zeros(12)
    for _ in range(200):
        real[0:3] = rng.normal(size=3)
        p = real[0:3] + rng.normal(size=3) * rng.uniform(0.2, 1.2)
        v = rng.normal(size=3) * rng.uniform(0.01, 1.0)
        h = 1e-4

        def radius(t):
            return float(np.linalg.norm(p + v * t - real[0:3]))

        second = (radius(h) - 2.0 * radius(0.0) + radius(-h)) / (h * h)
        assert outward_drift(real, p, v) == pytest.approx(second, rel=1e-5, abs=1e-7)
    p = real[0:3] + np.array([0.8, 0.0, 0.0])
    assert outward_drift(real, p, np.array([0.3, 0.0, 0.0])) == 0.0
    assert outward_drift(real, p, np.array([0.0, 0.4, 0.0])) == pytest.approx(0.16 / 0.8, rel=1e-12)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_each_rows_pull_and_drift_are_how_fast_the_arm_coasts_toward_it(name):
    """The rows' ``pull`` and ``drift`` at a random joint velocity, the arm coasting on (no
    joint acceleration), against finite differences of pinocchio's kinematics (independent of
    the compiled Jacobians). ``pull``: on the extended reach's row, the second derivative of the
    hand's distance to the sphere's centre as it moves straight on at its velocity now (minus it
    on the inner reach's row: the curvature draws the hand away from it); zero on every other row
    (planes, joint limits, zones and people do not pull). ``drift``: minus the
    second derivative, along the row's direction, of the row's point carried by its link (the
    hand for the reach) along ``q (+) t qdot``; zero on the joints' rows."""
    model = robot(name)
    rng = np.random.default_rng(2000 + ROBOT_NAMES.index(name))
    ee_joint = model.model.frames[model.ee_frame_id].parentJoint
    pulled, drifted = 0, 0
    for _ in range(10):
        q = random_configuration(model.model, rng)
        qdot = rng.normal(size=model.nv) * rng.uniform(0.1, 1.5)
        kin_o = Kinematics(model, q)
        limitations, human, ahead_s, activation = random_scene(model, kin_o, rng)
        pack = pack_scene(limitations, model)
        kin = compiled_kinematics(model, q, qdot)[0]
        hum = human_tuple(human.p0, human.p1, human.radius, human.v0, human.v1, ahead_s)
        *_, tag, pull, drift, _ = compiled_pulls(pack, model, kin, hum, np.inf)
        expected, _ = oracle.rows(limitations, kin_o, human.ahead(ahead_s), np.inf)
        h = 1e-6
        v_hand = (Kinematics(model, pin.integrate(model.model, q, qdot * h)).p_ee
                  - Kinematics(model, pin.integrate(model.model, q, -qdot * h)).p_ee) / (2.0 * h)
        coasted = {t: Kinematics(model, pin.integrate(model.model, q, qdot * t)) for t in (-1e-3, 1e-3)}
        for (con, side, b), got, got_drift, row in zip(tag, pull, drift, expected, strict=True):
            lim = limitations[con]
            if isinstance(lim, ReachLimits):
                centre, t = np.array(lim.shoulder), 1e-3

                def radius(t, centre=centre):
                    return float(np.linalg.norm(kin_o.p_ee + v_hand * t - centre))

                second = (radius(t) - 2.0 * radius(0.0) + radius(-t)) / (t * t)
                assert got == pytest.approx(second if side == 1 else -second, rel=1e-4, abs=1e-6)
                pulled += got > 1e-3
            else:
                assert got == 0.0
            if row.angular:
                assert got_drift == 0.0
                continue
            joint = ee_joint if isinstance(lim, ReachLimits) else kin_o.capsule_joint[side]
            local = kin_o.data.oMi[joint].actInv(row.point)  # the row's point in its link's frame
            moved = {t: k.data.oMi[joint].act(local) for t, k in coasted.items()}
            second = (moved[1e-3] - 2.0 * row.point + moved[-1e-3]) / 1e-6
            assert got_drift == pytest.approx(-row.normal @ second, rel=1e-4, abs=1e-5)
            drifted += abs(got_drift) > 0.1
    assert pulled >= 5 and drifted >= 50


def _zone_rows_against_their_distance(seed: int, states: int = 30):
    """Every capsule or sphere zone row of ``random_scene`` at random states and joint
    velocities, over all robots: ``(drift, the true approach, whether the row's closest point
    lies inside its capsule's segment)``, the true approach being minus the second derivative of
    the capsule's clearance from the zone (an end's row: that end's) (the oracle's
    ``capsule_pair``, independent of the compiled geometry) as the arm coasts along ``q (+) t
    qdot``, by central differences. Rows whose closest point moves between an end and the
    segment's inside within the difference's step (a kink) are left out."""
    found = []
    h = 1e-4
    for name in ROBOT_NAMES:
        model = robot(name)
        rng = np.random.default_rng(seed + ROBOT_NAMES.index(name))
        for _ in range(states):
            q = random_configuration(model.model, rng)
            qdot = rng.normal(size=model.nv) * rng.uniform(0.1, 1.5)
            limitations, human, ahead_s, _ = random_scene(model, Kinematics(model, q), rng)
            kin = compiled_kinematics(model, q, qdot)[0]
            hum = human_tuple(human.p0, human.p1, human.radius, human.v0, human.v1, ahead_s)
            *_, tag, _, drift, _ = compiled_pulls(pack_scene(limitations, model), model, kin, hum, np.inf)
            coasted = [Kinematics(model, pin.integrate(model.model, q, qdot * t)) for t in (-h, 0.0, h)]
            for (con, c, b), got in zip(tag, drift, strict=True):
                zone = limitations[con]
                if not isinstance(zone, (SphereZone, CapsuleZone)):
                    continue
                z0, z1 = ((zone.center, zone.center) if isinstance(zone, SphereZone) else (zone.p0, zone.p1))
                clearance, inside = [], []
                for k in coasted:
                    a0, a1 = (k.p0[c], k.p1[c]) if b == 0 else ((k.p0[c],) * 2 if b == 1 else (k.p1[c],) * 2)
                    d, pa, _ = capsule_pair(a0, a1, k.radius[c], np.array(z0), np.array(z1), zone.radius_m)
                    axis = k.p1[c] - k.p0[c]
                    s = float((pa - k.p0[c]) @ axis / (axis @ axis)) if axis @ axis > 0.0 else 0.0
                    clearance.append(d)
                    inside.append(1e-6 < s < 1.0 - 1e-6)
                if len(set(inside)) > 1:
                    continue
                approach = -(clearance[0] - 2.0 * clearance[1] + clearance[2]) / (h * h)
                found.append((float(got), approach, inside[1]))
    return found


def test_a_zone_rows_drift_at_a_segments_end_is_at_least_how_fast_its_clearance_closes():
    """Where a zone row's closest point is an end of the robot capsule's segment, its ``drift``
    (the point's own acceleration along the row, ``kinematics.drift_along``) is never less than
    how fast the capsule's true clearance closes as the arm coasts: the point is the closest
    one, and the row's direction turning as it moves only bends the clearance away (convex
    zones). A braking planned on the drift is then never short."""
    rows = [(got, approach) for got, approach, inside in _zone_rows_against_their_distance(7000) if not inside]
    assert len(rows) > 300
    short = [(got, approach) for got, approach in rows if got < approach - 1e-3]
    assert not short, short[:5]
    assert sum(approach < got - 0.05 for got, approach in rows) > 20  # the turning's slack is there


@pytest.mark.xfail(strict=True, reason=(
    "a capsule's closest point inside its segment slides along it as the link turns, and the clearance, "
    "a minimum over the segment, closes faster than that point's own motion says (the envelope: d'' = "
    "f_tt - g^T H^-1 g): on 4 % of these rows by more than 0.05 m/s^2, up to 5.9 m/s^2 (the kinova); the "
    "iiwa's wrist past the demo's sphere zone in a held-out hand drag closed at 0.86 m/s^2 where the row "
    "said it receded at 0.06 (docs/motion_limits.md, 'Held-out drags by the thousand'). Counting it in the "
    "drift was tried and made the hand drags worse (docs/tried/zone_sliding_drift.patch); the zone's rows at "
    "the capsule's ends brake the end the closest point slides to instead"))
def test_a_zone_rows_drift_inside_a_segment_is_at_least_how_fast_its_clearance_closes():
    """The same where the closest point lies inside the segment."""
    rows = [(got, approach) for got, approach, inside in _zone_rows_against_their_distance(7000) if inside]
    assert len(rows) > 100
    short = [(got, approach) for got, approach in rows if got < approach - 1e-3]
    assert not short, f"{len(short)} of {len(rows)} rows short, e.g. {short[:3]}"
