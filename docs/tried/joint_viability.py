"""Offline diagnostic (docs/motion_limits.md, "Two limitations at once"; not part of the package):
at steps of a scripted run, is there a joint trajectory (accelerations piecewise constant over
knots of h seconds, within each joint's acceleration and jerk limits and the hand's box) that
stops the arm before every limitation row within 0.5 (linearised at the step)? LP feasibility
(scipy's HiGHS), for two knot spacings.

    NUMBA_DISABLE_JIT=1 python docs/tried/joint_viability.py iiwa 0.00099 drag-turns 1864 1892 4

(robot, period [s], drag-turns | drag-release, first step, last step, every n steps). The rows
are the filter's own (``limitation_bounds``' arguments, captured), the buffers 1 mm / 1 mrad."""
import os, sys, pickle, numpy as np
assert os.environ.get("NUMBA_DISABLE_JIT") == "1"
from cobotsafety.arm import step_kernel as sk
from cobotsafety.arm.motion_box import EE_AXIS_SHARE
robot, dt, run_name, k0, k1, every = sys.argv[1], float(sys.argv[2]), sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
k = [0]; snaps = {}
orig_lb = sk.limitation_bounds
def lb(dist, A, rate, angular, separation, pull, drift, count, q0, qdot_prev, qddot_prev, *rest):
    if k0 <= k[0] <= k1 and (k[0] - k0) % every == 0:
        snaps.setdefault(k[0], {}).update(dist=dist[:count].copy(), A=A[:count].copy(), angular=angular[:count].copy(),
                                          pull=pull[:count].copy(), qdot=qdot_prev.copy(), qddot=qddot_prev.copy())
    return orig_lb(dist, A, rate, angular, separation, pull, drift, count, q0, qdot_prev, qddot_prev, *rest)
sk.limitation_bounds = lb
orig_fr = sk.filter_rows
def fr(q0, B, N, b, ramp_b, group, count, J, *rest):
    if k[0] in snaps:
        snaps[k[0]]["J"] = J.copy()
    return orig_fr(q0, B, N, b, ramp_b, group, count, J, *rest)
sk.filter_rows = fr
from cobotsafety.arm.controller import ArmController
from cobotsafety.experiments import limit_runs as lr
c = ArmController(robot)
lim = c.model.limits
acc, jerk = np.asarray(lim.acceleration_rad_s2), np.asarray(lim.jerk_rad_s3)
ee_box = EE_AXIS_SHARE * lim.ee_acceleration_m_s2
gen = {"drag-turns": lr.drag_turns, "drag-release": lr.drag_release}[run_name](c, dt)
sos = {}
for v in gen:
    k[0] += 1
    if k[0] > k1: break
    r = c.step(v, dt, "anticipative")
    sos[k[0]] = r.safety_over_smoothness
from scipy.optimize import linprog
def feasible(s, h, n_knots, buffer=1e-3):
    nv = s["qdot"].shape[0]; n = n_knots
    nx = n * nv
    A_ub, b_ub = [], []
    # velocity after m knots: v_m = v0 + h sum_{l<m} u_l ; position: q_m - q0 = h sum_{l<m} v_l + h^2/2 sum u_l
    # = m h v0 + h^2 sum_{l<m} (m - l - 1/2) u_l
    def pos_coeff(m):
        C = np.zeros((nv, nx))
        for l in range(m):
            C[:, l*nv:(l+1)*nv] = h*h*(m - l - 0.5)*np.eye(nv)
        return C, m*h*s["qdot"]
    # rows: dist_i - buffer + A_i (q_m - q0) >= 0 for m = 1..n  (and after the stop the arm is still)
    gaps = s["dist"] - np.where(s["angular"], buffer, buffer)
    for m in range(1, n + 1):
        C, c0 = pos_coeff(m)
        for i in range(len(gaps)):
            if gaps[i] > 0.5: continue
            A_ub.append(-(s["A"][i] @ C)); b_ub.append(gaps[i] + s["A"][i] @ c0)
    # jerk: |u_l - u_{l-1}| <= jerk h, u_{-1} = qddot
    for l in range(n):
        for j in range(nv):
            row = np.zeros(nx); row[l*nv+j] = 1
            prev = s["qddot"][j] if l == 0 else 0.0
            if l > 0: row[(l-1)*nv+j] = -1
            A_ub.append(row); b_ub.append(jerk[j]*h + prev)
            A_ub.append(-row); b_ub.append(jerk[j]*h - prev)
    # hand box on J u
    J = s["J"][:3]
    for l in range(n):
        for r in range(3):
            row = np.zeros(nx); row[l*nv:(l+1)*nv] = J[r]
            A_ub.append(row); b_ub.append(ee_box); A_ub.append(-row); b_ub.append(ee_box)
    # stop: v_n = 0
    A_eq = np.zeros((nv, nx)); 
    for l in range(n): A_eq[:, l*nv:(l+1)*nv] = h*np.eye(nv)
    b_eq = -s["qdot"]
    bounds = [(-acc[j], acc[j]) for l in range(n) for j in range(nv)]
    res = linprog(np.zeros(nx), A_ub=np.array(A_ub), b_ub=np.array(b_ub), A_eq=A_eq, b_eq=b_eq, bounds=bounds, method="highs")
    return res.status == 0
for kk in sorted(snaps):
    s = snaps[kk]
    if "J" not in s: continue
    f = [feasible(s, h, n) for h, n in ((0.003, 200), (0.015, 40))]
    near = [(round(float(d),4)) for d in s["dist"] if d < 0.02]
    print(kk, "jointly stoppable (3 ms x 200, 15 ms x 40):", f, "counted" if sos.get(kk) else "", "near rows:", near, flush=True)
