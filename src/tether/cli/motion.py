"""Commands on the observer's motions: bound, plot-motion."""

from __future__ import annotations

import argparse
import math

from tether.cli.common import add_speeds, check_plot_arg, float_arg, print_json
from tether.errors import InvalidParameterError
from tether.tolerances import ANGLE_MAX

__all__ = ["check_angles", "cmd_bound", "cmd_plot_motion", "register"]


def cmd_bound(args: argparse.Namespace) -> int:
    """``tether bound``: rotation time and distance bounds for a sweep; exit status."""
    from tether.bounds import bound_report

    check_plot_arg(args)
    check_angles(args)
    rep = bound_report(args.theta0, args.thetaf, args.vt, args.vo, args.lss)
    if args.plot:
        from tether.plot import bound_figure, save

        save(bound_figure(args.theta0, args.thetaf, args.vt, args.vo, args.lss), args.plot)
    if args.json:
        print_json(rep)
        return 0
    sweep = abs(args.thetaf - args.theta0)
    sense = "CCW" if args.thetaf >= args.theta0 else "CW"
    print(f"rotation {math.degrees(sweep):.2f}° {sense}, vt={args.vt:g}, vo={args.vo:g}, "
          f"lss={args.lss:g}")
    print(f"  straight target (paper's L):  time {rep['rotation_time']:.6g} s, "
          f"distance bound L = {rep['distance_bound']:.6g}")
    print(f"  steering target (safe bound): time {rep['worst_case_time']:.6g} s, "
          f"distance bound L_g = {rep['worst_case_distance']:.6g}")
    return 0


def check_angles(args: argparse.Namespace) -> None:
    """Reject ``--from``/``--to`` beyond ``ANGLE_MAX`` radians (where every digit of the angle
    that matters for the rotation is lost)."""
    for flag, v in (("--from", args.theta0), ("--to", args.thetaf)):
        if not math.isfinite(v) or abs(v) > ANGLE_MAX:
            raise InvalidParameterError(f"{flag} {v:g} is out of range: use an angle in "
                                        f"radians within ±{ANGLE_MAX:g}")


def cmd_plot_motion(args: argparse.Namespace) -> int:
    """``tether plot-motion``: a figure of one observer motion; exit status."""
    from tether import plot
    from tether._util.files import IMAGE_KINDS, check_output_path
    from tether.bounds import check_speeds

    check_output_path(args.out, IMAGE_KINDS)
    check_speeds(args.vt, args.vo, args.lss)
    check_angles(args)
    if args.vt == 0:
        raise InvalidParameterError("plot-motion needs vt > 0: a target that does not move "
                                    "draws no motion")
    fig, ax = plot.new_axes()
    if args.kind == "tractrix":
        plot.plot_tractrix(ax, args.lss, args.vt)
    elif args.kind == "rotation":
        plot.plot_rotation(ax, args.vt, args.vo, args.lss, args.theta0, args.thetaf)
    elif args.kind == "wall":
        plot.plot_wall(ax, args.vt, args.vo, args.lss, h=0.6 * args.lss)
    else:
        plot.plot_vertex(ax, args.vt, args.vo, args.lss, lt=0.6 * args.lss)
    plot.save(fig, args.out)
    print(f"wrote {args.out}")
    return 0


def register(add) -> None:
    """Add this group's subcommands; ``add(name, fn, help)`` returns the subparser."""
    sp = add("bound", cmd_bound, "rotation time and distance bound L of a saturated rotation")
    add_speeds(sp, required=True)
    sp.add_argument("--from", dest="theta0", type=float_arg, required=True, metavar="TH0",
                    help="start angle: the paper's θ (docs/formulas.md), radians, lifted")
    sp.add_argument("--to", dest="thetaf", type=float_arg, required=True, metavar="THF",
                    help="goal angle, radians, lifted: the sense is the sign of THF - TH0")
    sp.add_argument("--json", action="store_true", help="print JSON")
    sp.add_argument("--plot", metavar="FILE", help="also draw L against the rotation angle")

    sp = add("plot-motion", cmd_plot_motion, "draw an observer motion (paper Figs. 2-5)")
    sp.add_argument("kind", choices=["tractrix", "rotation", "wall", "vertex"])
    add_speeds(sp, required=False)
    sp.add_argument("--from", dest="theta0", type=float_arg, default=0.0, metavar="TH0",
                    help="rotation: start angle θ, radians (default 0)")
    sp.add_argument("--to", dest="thetaf", type=float_arg, default=2 * math.pi,
                    metavar="THF", help="rotation: goal angle θ, radians (default 2π)")
    sp.add_argument("--out", required=True, metavar="FILE", help="image file to write")
