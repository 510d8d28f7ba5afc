"""Figure 12 (beyond the paper): what the held-out evaluation sees, torque by torque.

The torque sweep of ``python -m pes_ref evaluate`` (50 torques evenly from the minimum to
the maximum, started like the paper's batch, seed 12345, 15 target periods), run on the
oscillator design (``--design``, the default: prescribed-gait shooting and its polish), on
gradient descent alone on eq. (6) aimed at 1.4 A (``--baseline``, made by
``design oscillator --plan overshoot``) and on the hand-drawn escapement
(:func:`pes_ref.synthesis.kinds.escapement.escapement_values`, no optimization), analysed by
:func:`pes_ref.synthesis.kinds.analysis.cycle_figures` over the last 3 periods. (a) amplitude of
q0 per torque, filled where the particle reaches the cycle (amplitude and period within 25%
of the targets, drift below 5% of A), with the 25% band; (b) how far q1 turns per target
period (:func:`pes_ref.synthesis.kinds.analysis.q1_advance`): the free-running speed
``tau / damping1`` is a straight line through the origin; an escapement holds q1 to a fixed
advance whatever the torque, and the gait the default design was trained on is ``gait_delta``.
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from figures import _common as C
from pes_ref.synthesis import CYCLE_TOLERANCE, cycle_figures, escapement_values, oscillator_torque_sweep, q1_advance

NAME = "fig12_torque_capture"
#: Held-out seed and particle count of ``evaluate``.
SEED, PARTICLES = 12345, 50
#: The baseline design: gradient descent alone (``--plan overshoot``).
BASELINE = "oscillator_overshoot"


def sweep_figures(problem, values, n, periods):
    """Torques, amplitude, captured mask and q1 advance per target period (last 3 periods)."""
    sweep = oscillator_torque_sweep(problem, values, n, periods, seed=SEED)
    amp, _, _, captured = cycle_figures(problem, sweep.traj)
    return sweep.torques, amp, captured, q1_advance(problem, sweep.traj)


def baseline_state(args):
    """The ``--baseline`` design (default ``OUT/cache/oscillator_overshoot.npz``, which make figures
    computes; with --smoke and no file, a tiny one made by the design command)."""
    from pes_ref.cli import main as cli_main
    path = args.baseline
    if path is None and args.smoke:
        path = os.path.join(args.out, "cache", f"{BASELINE}-smoke.npz")
        os.makedirs(os.path.dirname(path), exist_ok=True)
        if cli_main(["design", "oscillator", "--plan", "overshoot", "--smoke", "--quiet", "--force",
                     "--out", path]) != 0:
            raise SystemExit("the smoke baseline design failed")
    elif path is None:
        path = os.path.join(args.out, "cache", f"{BASELINE}.npz")
    if not os.path.exists(path):
        raise SystemExit(f"no baseline design at {path}: run `make figures` (or `python -m pes_ref design "
                         f"oscillator --plan overshoot --out {path}`), or pass --baseline FILE.npz")
    return C.design_state(argparse.Namespace(design=path, smoke=False, out=args.out), "oscillator")


def row_label(state, name: str) -> str:
    return f"{name} ({C.design_work(state)})"


def main(argv=None) -> int:
    parser = C.parser(__doc__.splitlines()[0], design_kind="oscillator")
    parser.add_argument("--baseline", default=None, metavar="FILE.npz",
                        help=f"the gradient-descent design drawn for comparison (default OUT/cache/{BASELINE}.npz)")
    args = parser.parse_args(argv)
    state = C.design_state(args, "oscillator")
    base = baseline_state(args)
    p = state.problem
    n, periods = (8, 4) if args.smoke else (PARTICLES, None)
    rows = [(row_label(state, "design"), "#1f77b4", "o", state.values),
            (row_label(base, "gradient descent alone, `--plan overshoot`"), "#2ca02c", "^", base.values),
            ("hand-drawn escapement (not optimized)", "#d62728", "s", escapement_values(p, state.values.shape))]
    fig, (ax0, ax1) = C.plt.subplots(1, 2, figsize=(13, 4.8), constrained_layout=True)
    A = p.amplitude
    ax0.axhspan((1 - CYCLE_TOLERANCE) * A, (1 + CYCLE_TOLERANCE) * A, color="#dddddd",
                label=f"target amplitude A = {A:g} +- {CYCLE_TOLERANCE:.0%}")
    for label, color, marker, values in rows:
        tau, amp, cap, adv = sweep_figures(p, values, n, periods)
        share = f"{np.mean(cap):.0%} captured"
        ax0.plot(tau[cap], amp[cap], marker, color=color, ms=5, label=f"{label}: {share}")
        ax0.plot(tau[~cap], amp[~cap], marker, mfc="none", color=color, ms=5)
        ax1.plot(tau, adv, marker + "-", color=color, ms=4, lw=0.8, label=label)
    tau = np.linspace(p.torque_min, p.torque_max, 2)
    ax1.plot(tau, tau / p.damping1 * p.period, "k--", lw=1, label="free running: (tau / damping1) x target period")
    ax1.axhline(p.gait_delta, color="k", ls=":", lw=1, label=f"the design's prescribed gait: {p.gait_delta:.3g} rad "
                                                             "per period")
    ax0.set_xlabel("torque tau on q1 (torque units)")
    ax0.set_ylabel("amplitude of q0 over the last 3 periods (length units)")
    ax0.set_title("(a) amplitude per torque; filled: reaches the cycle, open: does not")
    ax0.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    ax1.set_xlabel("torque tau on q1 (torque units)")
    ax1.set_ylabel("q1 turned per target period (rad)")
    ax1.set_title("(b) q1 advance per period over the last 3 periods")
    ax1.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    fig.suptitle("Fig. 12  The held-out torque sweep of `evaluate`, torque by torque "
                 f"(seed {SEED}, {n} particles)")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
