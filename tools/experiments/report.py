#!/usr/bin/python3
"""report.py [--require NAME...] [--] OUT_DIR: plots and OUT_DIR/report.md from the springbok-sim runs in OUT_DIR/<scenario>/.

Reads each run's summary.json (scores computed by springbok-sim, definitions in
tools/scenarios/README.md) and log.csv (measured vs template displacements).
Runs that are missing are listed as missing; nothing is invented.
With --require, the exit status is 1 unless every named run is present and
meets its targets (tools/reproduce --quick).
"""
import argparse
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

AXES = ["base_x", "base_y", "base_z", "ee_x", "ee_y", "ee_z"]
BASE_CASES = [("4", 4, 126.5), ("92", 92, 610), ("184", 184, 858)]
ARM_CASES = [("0p4", 0.4, 29), ("4", 4, 90), ("10", 10, 142)]
TROT_ARMS = [("0p4", 0.4), ("4", 4), ("10", 10)]
TROT_GAITS = [("gp1", 1.4, 0.55), ("gp2", 1.4, 0.65), ("gp3", 1.8, 0.55), ("gp4", 1.8, 0.65)]
TARGETS = {"arm_ee_nrmse": 0.03, "base_nrmse": 0.08, "steady": 0.01, "chirp_db": 2.0, "rot_nrmse": 0.05}
ROT_INERTIAS = [("0p1", 0.1, 4.5), ("0p4", 0.4, 9.0)]


def load_summary(out, name):
    path = os.path.join(out, name, "summary.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def list_runs(out):
    """Every run folder in OUT_DIR (one with a summary.json)."""
    return sorted(d for d in os.listdir(out) if os.path.exists(os.path.join(out, d, "summary.json")))


def load_log(out, name, columns):
    path = os.path.join(out, name, "log.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        header = f.readline().strip().split(",")
    missing = [c for c in columns if c not in header]
    if missing:
        raise SystemExit(f"report.py: {path}: missing columns {missing}")
    idx = [header.index(c) for c in columns]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=idx, ndmin=2)
    return {c: data[:, i] for i, c in enumerate(columns)}


def pct(v):
    return "n/a" if v is None else f"{100.0 * v:.2f} %"


def num(v, fmt="{:.2f}"):
    return "n/a" if v is None else fmt.format(v)


def save_figure(fig, out, filename, title=None, dpi=100):
    """Title, layout, write OUT_DIR/filename, close; returns filename (the report links it)."""
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(os.path.join(out, filename), dpi=dpi)
    plt.close(fig)
    return filename


def plot_cases(out, title, cases, axis_pairs, filename, ylabel="displacement [mm]"):
    """One panel per (scenario, label); each panel: measured vs template for the given columns (times 1000)."""
    fig, panels = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.4), squeeze=False)
    drawn = False
    for panel, (name, label) in zip(panels[0], cases):
        cols = ["time_s", "wbc_active"] + [c for pair in axis_pairs for c in pair[1:]]
        log = load_log(out, name, cols)
        panel.set_title(label, fontsize=10)
        panel.set_xlabel("time [s]")
        if log is None:
            panel.text(0.5, 0.5, "missing", ha="center", transform=panel.transAxes)
            continue
        on = log["wbc_active"] > 0.5
        t = log["time_s"][on]
        for (what, measured, template), colour in zip(axis_pairs, ["C0", "C1", "C2", "C3"]):
            panel.plot(t, 1000.0 * log[measured][on], color=colour, label=f"{what} measured")
            panel.plot(t, 1000.0 * log[template][on], color=colour, linestyle="--", label=f"{what} template")
        panel.set_ylabel(ylabel)
        panel.grid(True, alpha=0.3)
        drawn = True
    if drawn:
        panels[0][0].legend(fontsize=8)
    return save_figure(fig, out, filename, title, dpi=110)


def rise_time(out, name, measured, template):
    """Time from the push to 90 % of the final displacement (the speed of the response).

    The final displacement is the template's at the end of the run: its static response
    to the measured force, whatever the scenario's template parameters and force.
    """
    log = load_log(out, name, ["time_s", "fe_x_n", measured, template])
    if log is None:
        return None
    final = log[template][-1]
    pushed = np.nonzero(np.abs(log["fe_x_n"]) > 1.0)[0]
    if len(pushed) == 0 or abs(final) < 1e-9:
        return None
    t0 = log["time_s"][pushed[0]]
    reached = np.nonzero((log["time_s"] >= t0) & (log[measured] / final >= 0.9))[0]
    return None if len(reached) == 0 else log["time_s"][reached[0]] - t0


def final_template(out, name, template):
    """The template's displacement at the end of a run [m] (its static response to the force)."""
    log = load_log(out, name, ["time_s", template])
    return None if log is None else float(log[template][-1])


def deviation_time(out, name, axis):
    """When the largest |measured - template| happens, relative to the push."""
    log = load_log(out, name, ["time_s", "fe_x_n", f"{axis[:-2]}_d{axis[-1]}_m", f"template_{axis}_m"])
    if log is None:
        return None
    pushed = np.nonzero(np.abs(log["fe_x_n"]) > 1.0)[0]
    if len(pushed) == 0:
        return None
    err = np.abs(log[f"{axis[:-2]}_d{axis[-1]}_m"] - log[f"template_{axis}_m"])
    err[: pushed[0]] = 0.0  # after the push only
    return log["time_s"][int(np.argmax(err))] - log["time_s"][pushed[0]]


def mm(v):
    return "n/a" if v is None else f"{1000.0 * v:.1f}"


def trot_figure(out, title, runs, filename, t0=1.0, t1=8.0):
    """The paper's Fig. 8/9: base x (top) and EE x (bottom), measured vs template, one column per gait."""
    fig, panels = plt.subplots(2, len(runs), figsize=(3.6 * len(runs), 5.6), squeeze=False, sharex=True)
    for col, (name, label) in enumerate(runs):
        log = load_log(out, name, ["time_s", "wbc_active", "base_dx_m", "template_base_x_m", "ee_dx_m",
                                   "template_ee_x_m"])
        for row, (what, measured, template) in enumerate([("base x", "base_dx_m", "template_base_x_m"),
                                                          ("EE x", "ee_dx_m", "template_ee_x_m")]):
            panel = panels[row][col]
            panel.set_title(f"{label}: {what}", fontsize=9)
            panel.grid(True, alpha=0.3)
            if log is None:
                panel.text(0.5, 0.5, "missing", ha="center", transform=panel.transAxes)
                continue
            keep = (log["wbc_active"] > 0.5) & (log["time_s"] >= t0) & (log["time_s"] <= t1)
            t = log["time_s"][keep]
            panel.plot(t, 1000.0 * log[measured][keep], color="C0", label="measured")
            panel.plot(t, 1000.0 * log[template][keep], color="k", linestyle="--", label="template")
            if col == 0:
                panel.set_ylabel("displacement [mm]")
            if row == 1:
                panel.set_xlabel("time [s]")
    panels[0][0].legend(fontsize=8)
    return save_figure(fig, out, filename, title)


def wrench_figure(out, title, rows, filename, t0=1.5, t1=4.5):
    """The paper's Fig. 10: desired and applied x force on the base and their difference."""
    ncol = max(len(r) for _, r in rows)
    fig, panels = plt.subplots(len(rows), ncol, figsize=(3.6 * ncol, 2.8 * len(rows)), squeeze=False, sharex=True)
    for r, (row_label, runs) in enumerate(rows):
        for c, (name, label) in enumerate(runs):
            panel = panels[r][c]
            panel.set_title(f"{row_label}, {label}", fontsize=9)
            panel.grid(True, alpha=0.3)
            log = load_log(out, name, ["time_s", "wbc_active", "base_wrench_desired_fx_n", "base_wrench_applied_fx_n"])
            if log is None:
                panel.text(0.5, 0.5, "missing", ha="center", transform=panel.transAxes)
                continue
            keep = (log["wbc_active"] > 0.5) & (log["time_s"] >= t0) & (log["time_s"] <= t1)
            t = log["time_s"][keep]
            desired, applied = log["base_wrench_desired_fx_n"][keep], log["base_wrench_applied_fx_n"][keep]
            panel.plot(t, desired, color="C0", label="desired F_b,x")
            panel.plot(t, applied, color="C3", linestyle="--", label="applied")
            panel.plot(t, desired - applied, color="0.6", label="error")
            if c == 0:
                panel.set_ylabel("force [N]")
            if r == len(rows) - 1:
                panel.set_xlabel("time [s]")
    panels[0][0].legend(fontsize=7)
    return save_figure(fig, out, filename, title)


def hand_figure(out, log, filename):
    """The hand's rest point's circle and the hand (rest point + displacement) in the y-z plane."""
    fig, (path, err) = plt.subplots(1, 2, figsize=(10, 4.2))
    if log is not None:
        on = log["wbc_active"] > 0.5
        path.plot(1000 * log["hand_rest_dy_m"][on], 1000 * log["hand_rest_dz_m"][on], "k--", label="rest point (commanded)")
        path.plot(1000 * (log["hand_rest_dy_m"] + log["ee_dy_m"])[on], 1000 * (log["hand_rest_dz_m"] + log["ee_dz_m"])[on],
                  color="C0", alpha=0.8, label="hand")
        t = log["time_s"][on]
        err.plot(t, 1000 * (log["ee_dy_m"] - log["template_ee_y_m"])[on], label="y")
        err.plot(t, 1000 * (log["ee_dz_m"] - log["template_ee_z_m"])[on], label="z")
    path.set_xlabel("y [mm]")
    path.set_ylabel("z [mm]")
    path.set_aspect("equal")
    path.legend(fontsize=8)
    path.set_title("the hand's circle, from the engaged rest point")
    err.set_xlabel("time [s]")
    err.set_ylabel("tracking error [mm]")
    err.legend(fontsize=8)
    err.set_title("hand minus (rest point + template)")
    for a in (path, err):
        a.grid(True, alpha=0.3)
    return save_figure(fig, out, filename)


def hand_turn_figure(out, log, filename):
    """The hand's rest orientation (commanded) and the hand's, and the hand minus (rest + template)."""
    fig, (path, err) = plt.subplots(1, 2, figsize=(10, 4.2))
    if log is not None:
        on = log["wbc_active"] > 0.5
        t = log["time_s"][on]
        for a, colour in zip("xyz", ["C0", "C1", "C2"]):
            path.plot(t, 1000 * log[f"hand_rest_r{a}_rad"][on], color=colour, linestyle="--", label=f"rest r{a}")
            path.plot(t, 1000 * (log[f"hand_rest_r{a}_rad"] + log[f"ee_r{a}_rad"])[on], color=colour, alpha=0.8,
                      label=f"hand r{a}")
            err.plot(t, 1000 * (log[f"ee_r{a}_rad"] - log[f"template_ee_r{a}_rad"])[on], color=colour, label=f"r{a}")
    path.set_ylabel("rotation from the engaged orientation [mrad]")
    path.set_title("rest orientation (commanded) and the hand (small-angle sum)", fontsize=9)
    err.set_ylabel("hand minus (rest + template) [mrad]")
    err.set_title("rendering error", fontsize=9)
    for a in (path, err):
        a.set_xlabel("time [s]")
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    return save_figure(fig, out, filename)


STEP_HEADER = ["| scenario | NRMSE base x | NRMSE EE x | steady state base x | steady state EE x | peak dev base x [mm] | "
               "peak dev EE x [mm] | 90 % rise base / EE [s] | QP failures | max tau/limit | fell | joint limit | "
               "tick median / p99 [us] |",
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
CHIRP_HEADER = ["| scenario | NRMSE base | NRMSE EE | gain error base [dB] | gain error EE [dB] | QP failures | "
                "max tau/limit | fell | tick median / p99 [us] |", "|---|---|---|---|---|---|---|---|---|"]
WALK_HEADER = ["| scenario | command x, y, yaw | mean velocity x, y, yaw | NRMSE base y | NRMSE EE y | "
               "steady state base y / EE y | QP failures | max tau/limit | fell (s) |",
               "|---|---|---|---|---|---|---|---|---|"]


def add_rows(lines, checks, names, row_of):
    """A table's rows: row_of(n) gives each of `names` its (row, check); the row goes to `lines`, the check to `checks`."""
    for n in names:
        row, check = row_of(n)
        lines.append(row)
        checks.append(check)


def step_row(out, n, s):
    """A step run's table row and check: base_step_* scored on the base x, arm_step_* on the hand x."""
    if s is None:
        return f"| {n} | missing |" + " |" * 11, (n, False, "missing")
    nr, ss, pk = s["nrmse"], s["steady_state_error"], s["peak_deviation"]
    rb = rise_time(out, n, "base_dx_m", "template_base_x_m")
    re = rise_time(out, n, "ee_dx_m", "template_ee_x_m")
    row = (f"| {n} | {pct(nr['base_x'])} | {pct(nr['ee_x'])} | {pct(ss['base_x'])} | {pct(ss['ee_x'])} | "
           f"{num(pk['base_x'] and 1000 * pk['base_x'])} | {num(pk['ee_x'] and 1000 * pk['ee_x'])} | "
           f"{num(rb)} / {num(re)} | {s['qp_failures']} | {s['max_torque_ratio']:.3f} | {s['fell']} | "
           f"{s['joint_limit_hit'] or 'none'} | {s['tick_us']['median']:.1f} / {s['tick_us']['p99']:.1f} |")
    target = TARGETS["arm_ee_nrmse"] if n.startswith("arm") else TARGETS["base_nrmse"]
    key = "ee_x" if n.startswith("arm") else "base_x"
    ok = (nr[key] is not None and nr[key] <= target and all(ss[k] is not None and ss[k] <= TARGETS["steady"]
          for k in ("base_x", "ee_x")) and not s["fell"] and s["qp_failures"] == 0
          and s["max_torque_ratio"] <= 1.0 and not s["joint_limit_hit"])
    return row, (n, ok, f"{key} NRMSE {pct(nr[key])} (target {100 * target:.0f} %), steady state "
                        f"{pct(ss['base_x'])} / {pct(ss['ee_x'])} (target 1 %)")


def chirp_row(n, s):
    """A chirp run's (base_chirp_<axis>_*) table row and check: the gain error along its axis."""
    if s is None:
        return f"| {n} | missing |" + " |" * 7, (n, False, "missing")
    a = n.split("_")[2]
    nr, db = s["nrmse"], s["chirp_gain_db_error"] or {}
    row = (f"| {n} | {pct(nr['base_' + a])} | {pct(nr['ee_' + a])} | {num(db.get('base_' + a))} | "
           f"{num(db.get('ee_' + a))} | {s['qp_failures']} | {s['max_torque_ratio']:.3f} | {s['fell']} | "
           f"{s['tick_us']['median']:.1f} / {s['tick_us']['p99']:.1f} |")
    gains = [db.get("base_" + a), db.get("ee_" + a)]
    ok = (all(g is not None and g <= TARGETS["chirp_db"] for g in gains) and not s["fell"]
          and s["qp_failures"] == 0 and s["max_torque_ratio"] <= 1.0 and not s["joint_limit_hit"])
    return row, (n, ok, f"gain error {num(gains[0])} / {num(gains[1])} dB (target 2 dB)")


def walk_row(n, s):
    """A walk's table row and check: the mean velocity within 10 % or 0.03 of the command."""
    if s is None:
        return f"| {n} | missing |" + " |" * 7, (n, False, "missing")
    g = s["gait"] or {}
    cmd, mean = g.get("commanded_velocity", {}), g.get("mean_velocity", {})
    axes = ("x", "y", "yaw")
    misses = [a for a in axes
              if abs(mean.get(a, float("nan")) - cmd.get(a, 0.0)) > max(0.1 * abs(cmd.get(a, 0.0)), 0.03)
              or mean.get(a) is None]
    fell = f"{s['fell']} ({num(s['fell_time_s'])})" if s["fell"] else "False"
    row = (f"| {n} | {', '.join(num(cmd.get(a)) for a in axes)} | "
           f"{', '.join(f'{mean[a]:.3f}' for a in axes if a in mean)} | {pct(s['nrmse']['base_y'])} | "
           f"{pct(s['nrmse']['ee_y'])} | {pct(s['steady_state_error']['base_y'])} / "
           f"{pct(s['steady_state_error']['ee_y'])} | {s['qp_failures']} | "
           f"{s['max_torque_ratio']:.3f} | {fell} |")
    ok = not misses and not s["fell"] and s["max_torque_ratio"] <= 1.0 and not s["joint_limit_hit"]
    return row, (n, ok, "mean velocity " + ", ".join(f"{a} {mean.get(a, float('nan')):.3f}" for a in axes)
                 + " against " + ", ".join(f"{num(cmd.get(a))}" for a in axes)
                 + " (target 10 % or 0.03)" + (f", fell at {num(s['fell_time_s'])} s" if s["fell"] else ""))


def trot_row(n, s):
    """A trot's row of a robot's report (its gait, rendering, limits) and its check."""
    g = s["gait"] or {}
    fell = f"{s['fell']} ({num(s['fell_time_s'])})" if s["fell"] else "False"
    return (f"| {n} | {num(g.get('step_frequency_hz'))} | {num(g.get('duty_factor'))} | "
            f"{pct(s['nrmse']['base_x'])} | {pct(s['nrmse']['ee_x'])} | "
            f"{pct(s['steady_state_error']['base_x'])} | {pct(s['steady_state_error']['ee_x'])} | "
            f"{s['qp_failures']} | {s['max_torque_ratio']:.3f} | {fell} | "
            f"{s['tick_us']['median']:.1f} / {s['tick_us']['p99']:.1f} |"), trot_check(n, s)


def trot_check(n, s):
    """A trot's check: it stands to the end, within its torque and joint limits."""
    return (n, not s["fell"] and s["max_torque_ratio"] <= 1.0 and not s["joint_limit_hit"],
            f"stands to the end ({'fell at ' + num(s['fell_time_s']) + ' s' if s['fell'] else 'yes'}), "
            f"max tau/limit {s['max_torque_ratio']:.3f}, joint limit {s['joint_limit_hit'] or 'none'}")


def trot_study(out, trot_runs, trots, stance, checks):
    """The paper's trotting study (its section VI.C): tables of every axis, Fig. 8-10, its three claims."""
    lines = ["", "## Trotting in place with the 50 N step (push at 2 s): the paper's study", "",
             "The trot of `firmware/gait` (diagonal pairs, quintic + bump swing, planned in the trunk's "
             "horizontal frame, footholds re-planned every swing tick under the static ZMP of weight + wrist wrench) "
             "starts with the WBC at 0.5 s; " + STATE["words"] + "; each run lasts 30 s. Scores from the WBC start. "
             "The template (M_b 92 kg, K_b 1000 N/m, K_e 500 N/m; M_e 0.4 / 4 / 10 kg) is the arm steps' one, so "
             "the stance runs `arm_step_me*` are the same rendering without the gait.", "",
             "### Rendering along the pushed axis", "",
             "| scenario | M_e [kg] | gait | f_s [Hz] | d_f | NRMSE base x | NRMSE EE x | steady state base x | "
             "steady state EE x | rms(F_b,x^d - applied) [N] | QP failures | fell (s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n, m, g, fs, df in trot_runs:
        s = trots[n]
        if s is None:
            lines.append(f"| {n} | missing |" + " |" * 10)
            checks.append((n, False, "missing"))
            continue
        fell = f"{s['fell']} ({num(s['fell_time_s'])})" if s["fell"] else "False"
        checks.append(trot_check(n, s))
        lines.append(f"| {n} | {m} | {g.upper()} | {fs} | {df} | {pct(s['nrmse']['base_x'])} | "
                     f"{pct(s['nrmse']['ee_x'])} | {pct(s['steady_state_error']['base_x'])} | "
                     f"{pct(s['steady_state_error']['ee_x'])} | {num(s['base_wrench_error_rms']['fx_n'], '{:.1f}')} | "
                     f"{s['qp_failures']} | {fell} |")
    ran = [(n, trots[n]) for n, *_ in trot_runs if trots[n] is not None]  # the runs with a summary
    lines += ["", "### Every axis (RMS error from the WBC start)", "",
              "Translations: measured minus the template driven by the measured wrist force; orientations: the "
              "rotation vector from the rest pose's orientation (the template is translational: nothing is rendered "
              "there, the reference is the rest pose). The push is along x; y and z are the gait's own disturbance "
              "plus the template's small response to the measured force's y and z.", "",
              "| scenario | base x / y / z [mm] | base roll / pitch / yaw [mrad] | EE x / y / z [mm] | "
              "EE rx / ry / rz [mrad] | rms(W_b^d - applied): F y, z [N], T x, y, z [N m] |",
              "|---|---|---|---|---|---|"]
    for n, s in ran:
        e, w = s["rms_error"], s["base_wrench_error_rms"]
        lines.append(f"| {n} | {' / '.join(mm(e['base_' + a]) for a in 'xyz')} | "
                     f"{' / '.join(mm(e['base_r' + a]) for a in 'xyz')} | {' / '.join(mm(e['ee_' + a]) for a in 'xyz')} | "
                     f"{' / '.join(mm(e['ee_r' + a]) for a in 'xyz')} | "
                     f"{num(w['fy_n'], '{:.1f}')}, {num(w['fz_n'], '{:.1f}')}, {num(w['tx_nm'], '{:.1f}')}, "
                     f"{num(w['ty_nm'], '{:.1f}')}, {num(w['tz_nm'], '{:.1f}')} |")
    lines += ["", "### Limits and contacts", "",
              "Touch-downs: detected from each leg's estimated ground force (early: before the schedule's end of "
              "the swing, where the foothold's 5 mm below the ground puts them; late: the foot reached down past "
              "its foothold).", "",
              "Torque limits: the hip abduction joints and the arm's keep the URDF's flat effort; HyQ's hip and knee "
              "flexion joints are hydraulic cylinders on levers, whose limit is the cylinder's force limit (3600 N) "
              "times the lever arm at the joint's angle (81 N m at the ends of each range, 162 N m mid-range; "
              "ACTUATORS.md). The 3600 N is the source's, the same both directions: a cylinder pulling on its rod side "
              "has 61 % of the piston's area and may pull less at the same pressure; which direction pulls is not "
              "known. Each run's log.csv has the limit at every tick (tau_limit_<joint>).", "",
              "| scenario | max tau/limit | time with a joint >= 99 % of its torque limit [s] (most: joint, s) | "
              "max joint speed / limit (joint) | joint position limit | touch-downs early / late |",
              "|---|---|---|---|---|---|"]
    for n, s in ran:
        tl = s["torque_limit_s"]
        at_limit = f"{tl['any']:.3f} ({tl['most_joint']}, {tl['most']:.3f})" if tl["any"] > 0 else "0"
        lines.append(f"| {n} | {s['max_torque_ratio']:.3f} | {at_limit} | "
                     f"{s['max_joint_speed_ratio']:.3f} ({s['max_joint_speed_joint']}) | "
                     f"{s['joint_limit_hit'] or 'none'} | "
                     f"{(s['gait'] or {}).get('early_touchdowns', 'n/a')} / {(s['gait'] or {}).get('late_touchdowns', 'n/a')} |")

    figs = []
    for tag, m, label in (("0p4", 0.4, "low"), ("10", 10, "high")):
        figs.append(trot_figure(out, f"Trotting, {label} end-effector apparent inertia (M_e {m} kg): 50 N step along x "
                                "at 2 s (paper Fig. {})".format(8 if label == "low" else 9),
                                [(f"trot_me{tag}_{g}", f"{g.upper()} (f_s {fs}, d_f {df})") for g, fs, df in TROT_GAITS],
                                f"trot_me{tag}.png"))
    figs.append(wrench_figure(out, "Desired and applied x force on the base while trotting (paper Fig. 10)",
                              [(f"M_e {m}", [(f"trot_me{tag}_{g}", g.upper()) for g, _, _ in TROT_GAITS])
                               for tag, m in (("0p4", 0.4), ("10", 10))], "trot_base_force.png"))

    # The paper's three claims, with our numbers.
    lines += ["", "### The paper's trotting claims against these runs", ""]
    by = {(m, g): trots[n] for n, m, g, _, _ in trot_runs if trots[n] and not trots[n]["fell"]}
    fell = [n for n, *_ in trot_runs if trots[n] and trots[n]["fell"]]
    if fell:
        lines.append("- Runs that fell are left out of the comparisons: " + ", ".join(fell) + ".")
    gps = [g for g, _, _ in TROT_GAITS]
    arms = [m for _, m in TROT_ARMS]

    def ee(m, g):
        return by[(m, g)]["nrmse"]["ee_x"] if (m, g) in by else None

    def base(m, g):
        return by[(m, g)]["nrmse"]["base_x"] if (m, g) in by else None

    # 1: "the impedance rendering is significantly more sensitive to trotting gaits for higher apparent inertias":
    # what the trot adds to the same template's error in stance (arm_step_me*: same template, no gait).
    arm_stance = {m: stance.get(f"arm_step_me{t}") for t, m in TROT_ARMS}
    added, parts = {}, []
    for m in arms:
        vals = [ee(m, g) for g in gps if ee(m, g) is not None]
        st = arm_stance.get(m)
        if vals and st and st["nrmse"]["ee_x"] is not None:
            mean = sum(vals) / len(vals)
            added[m] = mean - st["nrmse"]["ee_x"]
            parts.append(f"M_e {m}: {pct(mean)} trotting against {pct(st['nrmse']['ee_x'])} in stance "
                         f"({100 * added[m]:+.2f} points)")
    lo = arms[0]
    if len(added) == len(arms):
        grows = all(added[a] < added[b] for a, b in zip(arms, arms[1:]))
        lines.append("1. *The rendering is more sensitive to the trot at higher end-effector inertia.* EE x NRMSE, "
                     "mean over GP1-GP4, against the same template's stance run: " + "; ".join(parts) + ". "
                     + ("Ours agree: what the trot adds grows with M_e. " if grows else
                        "Ours disagree: what the trot adds does not grow with M_e. ")
                     + (f"In absolute terms the light hand's error is the largest: in stance already its template "
                        f"asks the arm for its speed limit ({arm_stance[lo]['max_joint_speed_joint']} at "
                        f"{arm_stance[lo]['max_joint_speed_ratio']:.3f} of it), and trotting does not add to that. "
                        if arm_stance[lo]["max_joint_speed_ratio"] >= 0.95 and added[lo] < 0 else "")
                     + "(The trots score 29.5 s, the stance runs 7.5 s, both from the WBC start.)")
    # 2: the duty factor matters more than the step frequency.
    rows = []
    agree = 0
    total = 0
    for m in arms:
        if all((m, g) in by for g in gps):
            d_df = [ee(m, "gp2") - ee(m, "gp1"), ee(m, "gp4") - ee(m, "gp3")]
            d_fs = [ee(m, "gp3") - ee(m, "gp1"), ee(m, "gp4") - ee(m, "gp2")]
            b_df = [base(m, "gp2") - base(m, "gp1"), base(m, "gp4") - base(m, "gp3")]
            b_fs = [base(m, "gp3") - base(m, "gp1"), base(m, "gp4") - base(m, "gp2")]
            bigger = sum(abs(x) for x in d_df) > sum(abs(x) for x in d_fs)
            agree += bigger
            total += 1
            rows.append(f"M_e {m}: raising d_f 0.55 -> 0.65 changes EE x NRMSE by "
                        f"{100 * d_df[0]:+.2f} / {100 * d_df[1]:+.2f} points (at f_s 1.4 / 1.8), raising f_s 1.4 -> 1.8 "
                        f"by {100 * d_fs[0]:+.2f} / {100 * d_fs[1]:+.2f} (at d_f 0.55 / 0.65); base x "
                        f"{100 * b_df[0]:+.2f} / {100 * b_df[1]:+.2f} against {100 * b_fs[0]:+.2f} / {100 * b_fs[1]:+.2f}")
    if rows:
        lines.append("2. *The tracking error is more sensitive to the duty factor than to the step frequency.* "
                     + "; ".join(rows) + f". The duty factor moves the EE error more in {agree} of {total} arm "
                     "inertias" + (": ours agree." if agree == total else (": ours disagree." if agree == 0 else
                                                                           ": ours agree only in part.")))
    # 3: larger duty factors and lower step frequencies help.
    helps_df = helps_fs = n_cmp = 0
    for m in arms:
        if all((m, g) in by for g in gps):
            n_cmp += 2
            helps_df += (ee(m, "gp2") < ee(m, "gp1")) + (ee(m, "gp4") < ee(m, "gp3"))
            helps_fs += (ee(m, "gp1") < ee(m, "gp3")) + (ee(m, "gp2") < ee(m, "gp4"))
    swing = {g: (1.0 - df) / fs for g, fs, df in TROT_GAITS}
    if n_cmp:
        def verdict(k):
            return "agree" if 2 * k > n_cmp else ("disagree" if 2 * k < n_cmp else "are split")
        lines.append(f"3. *Larger duty factors and lower step frequencies help.* The larger duty factor lowers EE x NRMSE "
                     f"in {helps_df} of {n_cmp} pairs (ours {verdict(helps_df)}); the lower step frequency in "
                     f"{helps_fs} of {n_cmp} (ours {verdict(helps_fs)})."
                     + ("" if 2 * helps_fs >= n_cmp else
                        " A reading consistent with our numbers, not a proof: the trunk drifts from its template "
                        "while on two feet, and at the higher step frequency each two-feet interval is shorter "
                        f"({swing['gp3']:.2f} s against {swing['gp1']:.2f} s at d_f 0.55), so it drifts less before "
                        "the next four-feet phase"
                        + ("; rms(F_b,x^d - applied) below is lower at GP3 than at GP1 for every M_e."
                           if all(by[(m, 'gp3')]["base_wrench_error_rms"]["fx_n"]
                                  < by[(m, 'gp1')]["base_wrench_error_rms"]["fx_n"] for m in arms) else ".")))
    ry = [by[k]["rms_error"]["ee_ry"] for k in by]
    if ry:
        lines.append(f"- The hand's orientation is not rendered (the paper's arm task is position only): under the 50 N "
                     f"push the hand pitches (EE ry rms {1000 * min(ry):.0f}-{1000 * max(ry):.0f} mrad), in stance as "
                     "much as trotting; only the arm's posture task in the null space holds it.")
    fx = {(m, g): by[(m, g)]["base_wrench_error_rms"]["fx_n"] for (m, g) in by}
    if fx:
        lines.append("- Fig. 10's quantity, rms(F_b,x^d - applied) over the run: "
                     + "; ".join(f"M_e {m}: " + ", ".join(f"{g.upper()} {fx[(m, g)]:.1f} N" for g in gps if (m, g) in fx)
                                 for m in arms) + ". On two feet the base wrench's rows cannot all be met "
                     "(the paper's relationship 1); the x force's error is the part the template then misses.")
    return lines, figs


def rot_step_figure(out, filename):
    """Torque steps: one row per hand inertia, one column per axis; trunk and hand, measured vs template."""
    fig, panels = plt.subplots(len(ROT_INERTIAS), 3, figsize=(12.6, 3.2 * len(ROT_INERTIAS)), squeeze=False,
                               sharex=True)
    for r, (t, inertia, _) in enumerate(ROT_INERTIAS):
        for c, a in enumerate("xyz"):
            panel = panels[r][c]
            panel.set_title(f"I_e = {inertia} kg m^2, 5 N m about {a}", fontsize=9)
            panel.grid(True, alpha=0.3)
            log = load_log(out, f"rot_step_{a}_ie{t}", ["time_s", "wbc_active", f"base_r{a}_rad",
                                                       f"template_base_r{a}_rad", f"ee_r{a}_rad", f"template_ee_r{a}_rad"])
            if log is None:
                panel.text(0.5, 0.5, "missing", ha="center", transform=panel.transAxes)
                continue
            on = log["wbc_active"] > 0.5
            tt = log["time_s"][on]
            for what, colour in (("base", "C0"), ("ee", "C1")):
                label = "trunk" if what == "base" else "hand"
                panel.plot(tt, 1000 * log[f"{what}_r{a}_rad"][on], color=colour, label=f"{label} measured")
                panel.plot(tt, 1000 * log[f"template_{what}_r{a}_rad"][on], color=colour, linestyle="--",
                           label=f"{label} template")
            if c == 0:
                panel.set_ylabel("rotation [mrad]")
            if r == len(ROT_INERTIAS) - 1:
                panel.set_xlabel("time [s]")
    panels[0][0].legend(fontsize=7)
    return save_figure(fig, out, filename, "Rotational template: 5 N m torque steps at the hand")


def rotational_study(out, checks):
    """The rotational template (beyond the paper): torque steps about each axis and chirps, two hand inertias."""
    steps = [(f"rot_step_{a}_ie{t}", a, i, d) for t, i, d in ROT_INERTIAS for a in "xyz"]
    chirps = [(f"rot_chirp_x_ie{t}", "x", i, d) for t, i, d in ROT_INERTIAS]
    runs = {n: load_summary(out, n) for n, *_ in steps + chirps}
    if not any(runs.values()):
        return [], []
    lines = ["", "## The rotational template at the hand (beyond the paper)", "",
             "`controller.params.rotational_template`: per axis of rotation the same two-body template for the "
             "trunk's orientation (I_b the composite inertia, D_rb 150 N m s/rad, K_rb 500 N m/rad) and the hand's "
             "relative to the trunk (I_e 0.1 or 0.4 kg m^2, critically damped: D_re 4.5 or 9 N m s/rad, K_re 50 "
             "N m/rad), driven by the *measured* wrist torque; orientation displacements are rotation vectors of "
             "R R_rest^T (world axes), the template integrated exactly per axis. The arm task is 6-D (the hand's "
             "position keeps the translational template, M_e 4). In stance, " + STATE["words"] + "; the torque acts "
             "from 1 s: a 5 N m step (steady state T/K_rb = 10 mrad for the trunk, T/K_rb + T/K_re = 110 mrad for the "
             "hand) or a 3 N m chirp 0-5 Hz over 10 s.", "",
             "| scenario | axis | I_e [kg m^2] | NRMSE base | NRMSE hand | steady state base / hand | "
             "gain error base / hand [dB] | max joint speed / limit | QP failures | fell |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for n, a, inertia, _ in steps + chirps:
        s = runs[n]
        if s is None:
            lines.append(f"| {n} | missing |" + " |" * 8)
            checks.append((n, False, "missing"))
            continue
        nr, ss, db = s["nrmse"], s["steady_state_error"], s["chirp_gain_db_error"] or {}
        kb, ke = "base_r" + a, "ee_r" + a
        chirp = n.startswith("rot_chirp")
        lines.append(f"| {n} | {a} | {inertia} | {pct(nr[kb])} | {pct(nr[ke])} | "
                     f"{'-' if chirp else pct(ss[kb]) + ' / ' + pct(ss[ke])} | "
                     f"{num(db.get(kb)) + ' / ' + num(db.get(ke)) if chirp else '-'} | "
                     f"{s['max_joint_speed_ratio']:.3f} ({s['max_joint_speed_joint']}) | {s['qp_failures']} | {s['fell']} |")
        ok = (all(nr[k] is not None and nr[k] <= TARGETS["rot_nrmse"] for k in (kb, ke)) and not s["fell"]
              and s["qp_failures"] == 0 and s["max_torque_ratio"] <= 1.0 and not s["joint_limit_hit"])
        why = f"NRMSE base / hand r{a} {pct(nr[kb])} / {pct(nr[ke])} (target 5 %)"
        if not chirp:
            ok = ok and all(ss[k] is not None and ss[k] <= TARGETS["steady"] for k in (kb, ke))
            why += f", steady state {pct(ss[kb])} / {pct(ss[ke])} (target 1 %)"
        checks.append((n, ok, why))
    figs = [rot_step_figure(out, "rot_step.png")]
    figs.append(plot_cases(out, "Rotational template, 3 N m torque chirp 0-5 Hz about x at the hand",
                           [(f"rot_chirp_x_ie{t}", f"I_e = {i} kg m^2") for t, i, _ in ROT_INERTIAS],
                           [("trunk rx", "base_rx_rad", "template_base_rx_rad"),
                            ("hand rx", "ee_rx_rad", "template_ee_rx_rad")], "rot_chirp_x.png", ylabel="rotation [mrad]"))
    return lines, figs


def robot_report(out, robot, present):
    """The report of a robot other than HyQ + Gen3 (tools/reproduce --robot NAME): its runs, classified by
    name (base_step*, arm_step*, base_chirp_<axis>_*, trot*, walk*), each against the same targets as
    HyQ's. Returns (lines, figures, checks)."""
    steps = [n for n in present if n.startswith(("base_step", "arm_step"))]
    chirps = [n for n in present if n.startswith("base_chirp_")]
    trots = [n for n in present if n.startswith("trot")]
    walks = [n for n in present if n.startswith("walk")]
    others = [n for n in present if n not in steps + chirps + trots + walks]
    summaries = {n: load_summary(out, n) for n in present}
    lines = [f"# {robot}: the paper's experiments in simulation", "",
             f"A build for this robot (`-DSPRINGBOK_ROBOT={robot}` or `-DSPRINGBOK_ROBOT_DIR`), its scenarios "
             "(`tools/scenarios/<robot>/`, or the robot-neutral `tools/scenarios/any_robot/`): each names its "
             "template and push in its opening comment. Scores and targets as in HyQ + Gen3's report: NRMSE = "
             "RMS(measured - template) / peak-to-peak(template) from the WBC start; steady state = |mean of the "
             "last second - F/K| / |F/K|; " + STATE["words"] + ", Bullet at 1 kHz."]
    checks, figs = [], []
    trot_header = ["| scenario | f_s [Hz] | d_f | NRMSE base x | NRMSE EE x | steady state base x | steady state EE x | "
                   "QP failures | max tau/limit | fell (s) | tick median / p99 [us] |",
                   "|---|---|---|---|---|---|---|---|---|---|---|"]
    sections = [("Step responses", STEP_HEADER, steps, lambda n: step_row(out, n, summaries[n])),
                ("Chirp responses", CHIRP_HEADER, chirps, lambda n: chirp_row(n, summaries[n])),
                ("Trotting in place with a push", trot_header, trots, lambda n: trot_row(n, summaries[n])),
                ("Walking on command", WALK_HEADER, walks, lambda n: walk_row(n, summaries[n]))]
    for title, header, names, row_of in sections:
        if not names:
            continue
        lines += ["", f"## {title}", ""] + header
        add_rows(lines, checks, names, row_of)
    if steps:
        figs.append(plot_cases(out, f"{robot}: step responses", [(n, n) for n in steps],
                               [("base x", "base_dx_m", "template_base_x_m"), ("EE x", "ee_dx_m", "template_ee_x_m")],
                               "step_x.png"))
    if others:
        lines += ["", "Other runs (no target): " + ", ".join(others)]
    lines += estimation_section(out, present, checks)
    lines += timing_section(out, present)
    return lines + targets_section(checks), figs, checks


# What the runs' base state was (their summaries' state_source and sensors), for the text.
STATE = {"words": "ground-truth base state"}


def describe_state(out, present):
    """STATE's words from the first run's summary: estimated (on which sensors) or the truth."""
    s = load_summary(out, present[0]) if present else None
    if s and s.get("state_source") == "estimated":
        STATE["words"] = f"estimated base state ({s.get('sensors', 'ideal')} sensors)"
    else:
        STATE["words"] = "ground-truth base state"


ESTIMATION_TARGETS = {"nrmse_ratio": 1.5, "tilt_mrad": 2.0, "velocity_m_s": 0.03, "yaw_deg_per_min": 1.0,
                      "drift_percent": 2.0}


def pushed_axis(n):
    """The axis a run's push is along (its scores' key): r<axis> for the rotational runs, rx for the
    hand's turn, y for the sideways chirps and the walks' sideways step, else x."""
    if n.startswith(("rot_step_", "rot_chirp_")):
        return "r" + n.split("_")[2]
    if n == "hand_turn":
        return "rx"
    return "y" if n.startswith("walk_") or n.startswith("base_chirp_y") else "x"


def estimation_section(out, present, checks):
    """Each run on the estimated state against its ground-truth twin (run_all: OUT_DIR/truth/<run>/),
    with the estimator's own errors against the simulator's truth, and the targets on them."""
    truth_dir = os.path.join(out, "truth")
    rows = []
    for n in present:
        s = load_summary(out, n)
        t = load_summary(truth_dir, n)
        e = s.get("estimator") or {}
        if s.get("state_source") != "estimated" or not e:
            continue
        a = pushed_axis(n)
        nr, tnr = s["nrmse"], (t or {}).get("nrmse", {})

        def pair(key):
            return f"{pct(tnr.get(key))} / {pct(nr.get(key))}"
        drift = e.get("position_drift_percent")
        rows.append(f"| {n} | {s.get('sensors', 'n/a')} | {a} | {pair('base_' + a)} | {pair('ee_' + a)} | "
                    f"{1000 * e['velocity_rms_error_m_s']:.1f} | {e['tilt_rms_error_mrad']:.2f} | "
                    f"{e['yaw_drift_deg_per_min']:.2f} | {e['distance_walked_m']:.2f} | "
                    f"{'n/a' if drift is None else f'{drift:.2f} %'} | {e['all_ok']} |")
        if n.startswith(("base_step_", "arm_step_", "base_chirp_")):
            limit = ESTIMATION_TARGETS["nrmse_ratio"]
            keys = ["base_" + a, "ee_" + a]
            ok = t is not None and all(nr.get(k) is not None and tnr.get(k) is not None and nr[k] <= limit * tnr[k]
                                       for k in keys)
            checks.append((f"{n} estimated", ok and e["all_ok"],
                           ", ".join(f"{k} NRMSE {pct(nr.get(k))} against {pct(tnr.get(k))} on the truth" for k in keys)
                           + f" (target <= {limit}x)"))
        elif n.startswith(("trot_", "walk_")):
            why = [f"tilt {e['tilt_rms_error_mrad']:.2f} mrad rms (target {ESTIMATION_TARGETS['tilt_mrad']})",
                   f"velocity {e['velocity_rms_error_m_s']:.3f} m/s rms (target {ESTIMATION_TARGETS['velocity_m_s']})"]
            ok = (e["tilt_rms_error_mrad"] <= ESTIMATION_TARGETS["tilt_mrad"]
                  and e["velocity_rms_error_m_s"] <= ESTIMATION_TARGETS["velocity_m_s"] and e["all_ok"])
            if n.startswith("trot_"):  # in place: the heading's drift
                ok = ok and abs(e["yaw_drift_deg_per_min"]) <= ESTIMATION_TARGETS["yaw_deg_per_min"]
                why.append(f"yaw drift {e['yaw_drift_deg_per_min']:.2f} deg/min "
                           f"(target {ESTIMATION_TARGETS['yaw_deg_per_min']})")
            elif drift is not None:  # a walk of 0.5 m or more (a turn on the spot has none)
                ok = ok and drift <= ESTIMATION_TARGETS["drift_percent"]
                why.append(f"position drift {drift:.2f} % of {e['distance_walked_m']:.2f} m walked "
                           f"(target {ESTIMATION_TARGETS['drift_percent']} %)")
            checks.append((f"{n} estimator", ok, ", ".join(why)))
    if not rows:
        return []
    return ["", "## The estimated state against the ground truth", "",
            "Every run above is on the *estimated* base state: the firmware's estimator (the scenario's "
            "`controller.params.estimator`, else the firmware's default) from the simulated sensors of the preset "
            "named (`springbok-sim --sensors`; mems: a BMI088-class IMU with its noise, bias instability and turn-on "
            "biases, encoders through the gear, joint torques and the wrist F/T with noise and offsets). Each was run "
            "again with the base from the simulator's ground truth (`--state-source truth`, the same sensors "
            "otherwise: `truth/<run>/`). NRMSE along the pushed axis, truth / estimated. The estimator's errors "
            "against the truth over the WBC's ticks (`summary.json` `estimator`): trunk velocity rms, tilt (the "
            "gravity direction in the trunk) rms, yaw drift per minute, horizontal position drift per metre walked "
            "(runs of 0.5 m or more).", "",
            "| run | sensors | axis | base NRMSE | EE NRMSE | velocity error [mm/s rms] | tilt error [mrad rms] | "
            "yaw drift [deg/min] | walked [m] | position drift | every estimate ok |",
            "|---|---|---|---|---|---|---|---|---|---|---|"] + rows


TIMING_TARGETS = {"p99": 1.5, "p99_9": 2.5}
TIMING_GROUPS = [("steps", ("base_step", "arm_step")), ("chirps", ("base_chirp",)), ("trots", ("trot",)),
                 ("walks", ("walk",)), ("hand poses", ("hand_",)), ("rotational template", ("rot_",))]


def quantile(sorted_v, fraction):
    """springbok-sim's percentile: the smallest value with at least `fraction` of the values at or below it."""
    i = int(np.ceil(fraction * len(sorted_v)))
    return float(sorted_v[min(len(sorted_v) - 1, max(i, 1) - 1)])


def tick_times(out, n):
    """A run's WBC tick times [us]: each tick's minimum over its timing runs (run_all --timing-runs:
    OUT_DIR/<run>/tick_us.txt, a column per run), and how many runs; None without the file or a WBC tick."""
    path = os.path.join(out, n, "tick_us.txt")
    if not os.path.exists(path):
        return None
    runs = np.loadtxt(path, ndmin=2)
    if runs.size == 0 or not np.isfinite(runs).all() or (runs < 0).any():
        raise SystemExit(f"report.py: {path}: empty, or a negative time or not a number in it")
    runs = runs[(runs > 0).all(axis=1)]  # 0: a tick before the WBC's start (the stand controller's)
    if runs.size == 0:
        return None
    return np.sort(runs.min(axis=1)), runs.shape[1]


def timing_section(out, present):
    """The tick's cost per run: median, p99 and p99.9 of each tick's minimum over its timing runs,
    against the flat worst case's targets (p99 within 1.5x the median, p99.9 within 2.5x), by group."""
    rows, groups = [], {}
    level, locked, counts = None, set(), set()
    for n in present:
        t = tick_times(out, n)
        if t is None:
            continue
        ticks, count = t
        s = load_summary(out, n) or {}
        level = level or s.get("kernels")
        locked.add(s.get("memory_locked"))
        counts.add(count)
        med, p99, p999 = quantile(ticks, 0.5), quantile(ticks, 0.99), quantile(ticks, 0.999)
        ok = p99 <= TIMING_TARGETS["p99"] * med and p999 <= TIMING_TARGETS["p99_9"] * med
        group = next((g for g, prefixes in TIMING_GROUPS if n.startswith(prefixes)), "other")
        groups.setdefault(group, []).append((med, p99 / med, p999 / med, ok))
        rows.append(f"| {n} | {med:.1f} | {p99:.1f} ({p99 / med:.2f}x) | {p999:.1f} ({p999 / med:.2f}x) | "
                    f"{ticks[-1]:.1f} | {'met' if ok else 'MISSED'} |")
    if not rows:
        return []
    lines = ["", "## Tick time: the worst case", "",
             f"The firmware's tick in each run (sensors in, the estimate, the WBC with its QP, the commands out), "
             f"kernels at {level or 'an unknown level'}, memory "
             f"{'locked' if locked == {True} else 'not locked everywhere'} (`springbok-sim --lock-memory`). "
             f"Each tick's time is its minimum over {', '.join(str(c) for c in sorted(counts))} runs of the scenario "
             "(`run_all --timing-runs`): the runs compute the same ticks, so the minimum is the tick's own cost "
             "without what the OS took from it. Targets: p99 within "
             f"{TIMING_TARGETS['p99']}x the median, p99.9 within {TIMING_TARGETS['p99_9']}x. The max is "
             "the first WBC tick's (its code and data not yet in a cache) in most runs: no target.", "",
             "| group | runs | median of medians [us] | worst p99 / median | worst p99.9 / median | targets met |",
             "|---|---|---|---|---|---|"]
    for g, _ in TIMING_GROUPS + [("other", ())]:
        v = groups.get(g)
        if v:
            lines.append(f"| {g} | {len(v)} | {np.median([x[0] for x in v]):.1f} | {max(x[1] for x in v):.2f}x | "
                         f"{max(x[2] for x in v):.2f}x | {sum(x[3] for x in v)} of {len(v)} |")
    return lines + ["", "| run | median [us] | p99 [us] | p99.9 [us] | max [us] | targets |",
                    "|---|---|---|---|---|---|"] + rows


def targets_section(checks):
    return ["", "## Targets", ""] + [f"- {'PASS' if ok else 'MISS'} {n}: {why}" for n, ok, why in checks]


def main():
    parser = argparse.ArgumentParser(description="plots and report.md from springbok-sim runs")
    parser.add_argument("--require", nargs="+", default=[], metavar="NAME",
                        help="exit 1 unless these runs are present and meet their targets")
    parser.add_argument("--robot", default="hyq_gen3", metavar="NAME",
                        help="the robot the runs are of (default hyq_gen3: the paper's full study)")
    parser.add_argument("out", metavar="OUT_DIR")
    args = parser.parse_args()
    out = args.out
    present = list_runs(out)
    if not present:
        print(f"report.py: no runs in {out}", file=sys.stderr)
        return 1
    describe_state(out, present)
    if args.robot != "hyq_gen3":
        lines, figs, checks = robot_report(out, args.robot, present)
        return write_report(out, lines, figs, checks, present, args.require)
    step_runs = [f"base_step_mb{t}" for t, _, _ in BASE_CASES] + [f"arm_step_me{t}" for t, _, _ in ARM_CASES]
    chirp_runs = [f"base_chirp_{a}_mb{t}" for a in "xy" for t, _, _ in BASE_CASES]
    summaries = {n: load_summary(out, n) for n in step_runs + chirp_runs}

    figs = [
        plot_cases(out, "Base inertia shaping, 50 N step along x: base x",
                   [(f"base_step_mb{t}", f"M_b = {m} kg, D_b = {d}") for t, m, d in BASE_CASES],
                   [("base x", "base_dx_m", "template_base_x_m")], "base_step_x.png"),
        plot_cases(out, "Arm inertia shaping, 50 N step along x: end-effector x",
                   [(f"arm_step_me{t}", f"M_e = {m} kg, D_e = {d}") for t, m, d in ARM_CASES],
                   [("EE x", "ee_dx_m", "template_ee_x_m")], "arm_step_x.png"),
    ]
    for a in "xy":
        figs.append(plot_cases(out, f"Base inertia shaping, 20 N chirp 0-5 Hz along {a}",
                               [(f"base_chirp_{a}_mb{t}", f"M_b = {m} kg") for t, m, _ in BASE_CASES],
                               [(f"base {a}", f"base_d{a}_m", f"template_base_{a}_m"),
                                (f"EE {a}", f"ee_d{a}_m", f"template_ee_{a}_m")], f"base_chirp_{a}.png"))

    lines = ["# Stance experiments (SPEC section 7, paper section VI) in simulation", ""]
    lines += ["Each run: `springbok-sim tools/scenarios/<scenario>.yaml` (Bullet, 1 kHz, " + STATE["words"] + ", "
              "all four feet in stance, the wrist F/T sensor as F_e). The robot starts on the nominal stance with the "
              "arm bent ([0, 0.6, 0, 1.9, 0, 0.9, 0] rad), the stand controller holds it for 0.5 s, then the WBC "
              "takes over and holds that pose as its reference; the push starts at t = 1 s. The template is driven by "
              "the *measured* wrist force and integrated exactly (ZOH matrix exponential). Scores are fractions "
              "(NRMSE = RMS(measured - template) / peak-to-peak(template) from the WBC start; steady state = "
              "|mean of the last second - F/K| / |F/K|). The chirp amplitude, 20 N, is our choice: the paper does not "
              "give one.", "",
              "**One controller.** Every stance and trot run below is `springbok::control::RobotController` "
              "(`firmware/control/`), the object the deployed binary `springbok` runs in its control mode over CAN "
              "and `springbok-on-sim` on the simulated robot; `springbok-sim` adds only the ground-truth override "
              "(where a scenario asks for it), the scoring and the CSV. `tests/control/test_one_controller.cpp` "
              "replays a run's recorded measurements through the firmware's control mode and gets the same torques "
              "bit for bit; the HIL suite (`tools/hil`) runs it over virtual CAN with the IMU and the wrist F/T on "
              "the bus.", ""]
    lines += ["## Step responses", ""] + STEP_HEADER
    checks = []
    add_rows(lines, checks, step_runs, lambda n: step_row(out, n, summaries[n]))
    lines += ["", "## Chirp responses (20 N, 0 to 5 Hz over 10 s)", "",
              "Gain error: short-time least-squares fits y ~ a sin(phi(t)) + b cos(phi(t)) + c at the chirp's own "
              "phase phi(t), over windows one local period long centred at local frequencies from 0.25 Hz to 3 Hz "
              "(each centre 25 % above the previous); the reported number is the largest |20 log10(A_measured / "
              "A_template)| over those windows.", ""] + CHIRP_HEADER
    add_rows(lines, checks, chirp_runs, lambda n: chirp_row(n, summaries[n]))

    trot_runs = [(f"trot_me{a}_{g}", m, g, fs, df) for a, m in TROT_ARMS for g, fs, df in TROT_GAITS]
    trots = {n: load_summary(out, n) for n, *_ in trot_runs}
    if any(trots.values()):
        trot_lines, trot_figs = trot_study(out, trot_runs, trots, summaries, checks)
        lines += trot_lines
        figs += trot_figs

    walk_runs = ["walk_forward", "walk_sideways", "walk_turn"]
    walks = {n: load_summary(out, n) for n in walk_runs}
    if any(walks.values()):
        lines += ["", "## Walking on command (GP2, the 30 N sideways step at the hand at 8 s)", "",
                  "`controller.params.gait.velocity: [v_x, v_y, yaw rate]` in the trunk's horizontal frame; the "
                  "template's rest pose walks with the command (ramped at 0.5 m/s^2, 1 rad/s^2) and the footholds "
                  "follow the hips' velocity. Mean velocity: the trunk's, over the last 3 s, in its horizontal frame. "
                  "Rendering: displacements from the walking rest pose against the template driven by the measured "
                  "force.", ""] + WALK_HEADER
        add_rows(lines, checks, walk_runs, lambda n: walk_row(n, walks[n]))
        lines += ["", "- Walking adds the gait's own motion to the scored displacements: the trunk rolls and yaws at "
                  "the step frequency (the hand, 0.65 m above the trunk, sways with it), and the base lags its "
                  "walking rest pose by a few millimetres (the steady-state column, relative to F/K). Both count as "
                  "rendering error here; in place (the trot table above) the same controller renders within a few "
                  "percent."]

    hand = load_summary(out, "hand_circle")
    if hand is not None:
        e = hand["rms_error"]
        log = load_log(out, "hand_circle", ["time_s", "wbc_active", "hand_rest_dy_m", "hand_rest_dz_m", "ee_dy_m",
                                             "ee_dz_m", "template_ee_y_m", "template_ee_z_m"])
        figs.append(hand_figure(out, log, "hand_circle.png"))
        track = max(e["ee_y"], e["ee_z"])
        ok = (hand["nrmse"]["ee_x"] is not None and hand["nrmse"]["ee_x"] <= TARGETS["arm_ee_nrmse"] and track <= 0.005
              and not hand["fell"] and hand["qp_failures"] == 0 and hand["max_joint_speed_ratio"] <= 1.0)
        checks.append(("hand_circle", ok, f"ee_x NRMSE {pct(hand['nrmse']['ee_x'])} (target 3 %), circle tracking "
                                          f"rms y / z {mm(e['ee_y'])} / {mm(e['ee_z'])} mm (target 5)"))
        lines += ["", "## Hand pose commands: a circle drawn under a push (beyond the paper)", "",
                  "`hand_circle`: in stance, the hand's rest point follows `controller.params.hand_trajectory` (a clamped "
                  "cubic spline through 97 waypoints: a 10 cm circle at 0.5 Hz in the y-z plane, six turns from 1 s) "
                  "while a 20 N step along x pushes the hand from 3 s. The template follows the moving rest point; "
                  "the scores are the displacements from it against the template driven by the measured force.", "",
                  "| scenario | NRMSE EE x (push) | steady state EE x | circle tracking rms y / z [mm] | "
                  "base rms x / y / z [mm] | max joint speed / limit | QP failures | fell |",
                  "|---|---|---|---|---|---|---|---|",
                  f"| hand_circle | {pct(hand['nrmse']['ee_x'])} | {pct(hand['steady_state_error']['ee_x'])} | "
                  f"{mm(e['ee_y'])} / {mm(e['ee_z'])} | {mm(e['base_x'])} / {mm(e['base_y'])} / {mm(e['base_z'])} | "
                  f"{hand['max_joint_speed_ratio']:.3f} ({hand['max_joint_speed_joint']}) | {hand['qp_failures']} | "
                  f"{hand['fell']} |"]

    turn = load_summary(out, "hand_turn")
    if turn is not None:
        e, nr, ss = turn["rms_error"], turn["nrmse"], turn["steady_state_error"]
        log = load_log(out, "hand_turn", ["time_s", "wbc_active"] + [f"{c}_r{a}_rad" for c in ("hand_rest", "ee", "template_ee")
                                                                      for a in "xyz"])
        figs.append(hand_turn_figure(out, log, "hand_turn.png"))
        track = max(e["ee_ry"], e["ee_rz"])
        ok = (nr["ee_rx"] is not None and nr["ee_rx"] <= TARGETS["rot_nrmse"] and ss["ee_rx"] is not None
              and ss["ee_rx"] <= TARGETS["steady"] and track <= 0.005 and not turn["fell"] and turn["qp_failures"] == 0
              and turn["max_joint_speed_ratio"] <= 1.0)
        checks.append(("hand_turn", ok, f"ee_rx NRMSE {pct(nr['ee_rx'])} (target 5 %), steady state {pct(ss['ee_rx'])} "
                                        f"(target 1 %), turn tracking rms ry / rz {mm(e['ee_ry'])} / {mm(e['ee_rz'])} "
                                        "mrad (target 5)"))
        lines += ["", "`hand_turn` (orientation; with the rotational template): the hand's rest orientation turns "
                  "0.4 rad about z, 0.3 rad about y and back (rotation vectors through a clamped cubic spline, 2-5 s) "
                  "while a 2 N m torque step about x acts from 2.5 s; the rotational template renders the torque "
                  "about the moving rest orientation.", "",
                  "| scenario | NRMSE hand rx (torque) | steady state hand rx | turn tracking rms ry / rz [mrad] | "
                  "hand position rms [mm] | max joint speed / limit | QP failures | fell |",
                  "|---|---|---|---|---|---|---|---|",
                  f"| hand_turn | {pct(nr['ee_rx'])} | {pct(ss['ee_rx'])} | {mm(e['ee_ry'])} / {mm(e['ee_rz'])} | "
                  f"{mm(max(e['ee_x'], e['ee_y'], e['ee_z']))} | {turn['max_joint_speed_ratio']:.3f} "
                  f"({turn['max_joint_speed_joint']}) | {turn['qp_failures']} | {turn['fell']} |"]

    rot_lines, rot_figs = rotational_study(out, checks)
    lines += rot_lines
    figs += rot_figs

    lines += estimation_section(out, present, checks)
    lines += timing_section(out, present)
    lines += targets_section(checks)

    lines += ["", "## Compared with the paper's findings", ""]
    arm = [summaries[f"arm_step_me{t}"] for t, _, _ in ARM_CASES]
    base = [summaries[f"base_step_mb{t}"] for t, _, _ in BASE_CASES]
    if all(arm):
        lines.append("- *In full stance the arm's rendering error is negligible*: end-effector x NRMSE "
                     + ", ".join(f"{pct(s['nrmse']['ee_x'])} (M_e {m})" for s, (_, m, _) in zip(arm, ARM_CASES))
                     + "; peak deviations "
                     + ", ".join(f"{1000 * s['peak_deviation']['ee_x']:.2f} mm" for s in arm)
                     + " against a displacement of "
                     + ", ".join(f"{num(1000 * (final_template(out, f'arm_step_me{t}', 'template_ee_x_m') or 0.0))} mm"
                                 for t, _, _ in ARM_CASES) + ".")
    if all(base):
        times = [deviation_time(out, f"base_step_mb{t}", "base_x") for t, _, _ in BASE_CASES]
        lines.append("- *The base deviates a little early in the transient*: base x peak deviation "
                     + ", ".join(f"{1000 * s['peak_deviation']['base_x']:.2f} mm at {num(tt)} s after the push "
                                 f"(M_b {m})" for s, tt, (_, m, _) in zip(base, times, BASE_CASES))
                     + " against a static displacement of "
                     + ", ".join(f"{num(1000 * (final_template(out, f'base_step_mb{t}', 'template_base_x_m') or 0.0))} mm"
                                 for t, _, _ in BASE_CASES) + ".")
        rises = [rise_time(out, f"base_step_mb{t}", "base_dx_m", "template_base_x_m") for t, _, _ in BASE_CASES]
        lines.append("- *The mass changes the speed of the response, never the steady state*: 90 % rise time of the "
                     "base " + ", ".join(f"{num(r)} s (M_b {m})" for r, (_, m, _) in zip(rises, BASE_CASES))
                     + "; steady-state error of the base "
                     + ", ".join(pct(s["steady_state_error"]["base_x"]) for s in base) + " of F/K_b.")
    if all(arm):
        rises = [rise_time(out, f"arm_step_me{t}", "ee_dx_m", "template_ee_x_m") for t, _, _ in ARM_CASES]
        lines.append("- Arm inertia shaping: 90 % rise time of the end-effector "
                     + ", ".join(f"{num(r)} s (M_e {m})" for r, (_, m, _) in zip(rises, ARM_CASES))
                     + "; steady-state error " + ", ".join(pct(s["steady_state_error"]["ee_x"]) for s in arm)
                     + " of F/K_b + F/K_e.")
    lines += ["- Differences from the paper's setup: simulation (Bullet), not the hardware; the base pose and twist "
              "are the firmware's estimate from simulated sensors (the section above compares the simulator's ground truth); the sphere feet are modelled at their contact point "
              "(`contact.foot_radius`), without which the base settled 4 % (M_b 92) to 8 % (M_b 184) past F/K_b "
              "because the horizontal ground forces act 2 cm below the foot frame.", ""]
    return write_report(out, lines, figs, checks, present, args.require)


def write_report(out, lines, figs, checks, present, require):
    """Writes OUT_DIR/report.md (with its targets' verdicts) and returns the exit status for --require."""
    lines += ["", "## Figures", ""] + [f"![{f}]({f})" for f in figs]
    # springbok-view's pages (tools/experiments/run_all): each run in 3D, opened from the file.
    views = sorted(n for n in present if os.path.isfile(os.path.join(out, n, "view.html")))
    if views:
        lines += ["", "## The runs in 3D", "",
                  "Each run's page (springbok-view: the robot, its feet's ground forces, the template's rest "
                  "points and masses, the wrist force; play, pause, seek, speed). Open it in a browser; no server.", ""]
        lines += [" · ".join(f"[{n}]({n}/view.html)" for n in views)]
        shots = sorted(f for f in os.listdir(os.path.join(out, "views")) if f.endswith(".png")) \
            if os.path.isdir(os.path.join(out, "views")) else []
        lines += [""] + [f"![{f}](views/{f})" for f in shots]
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"report.py: wrote {os.path.join(out, 'report.md')} ({len(present)} runs)")
    verdicts = {n: (ok, why) for n, ok, why in checks}
    failed = 0
    for n in require:
        ok, why = verdicts.get(n, (False, "missing, or no target for it"))
        print(f"report.py: {'PASS' if ok else 'MISS'} {n}: {why}")
        failed += 0 if ok else 1
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
