"""Plan the gains of every built-in material for the simulated display and draw the renderable
friction range over load (writes the repository's docs/images/gain-plan.png, or OUT.png; runs
from any folder).

    python examples/gain_plan_figure.py [OUT.png]
"""

import sys
from pathlib import Path

from surfhap.exchange.materials import builtin_names, load_material
from surfhap.render.drive import default_method
from surfhap.render.gain_plan import plan_gains
from surfhap.report.plan_figures import plot_gain_plans

out = sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "docs" / "images" / "gain-plan.png"
plans = []
for name in builtin_names():
    mat = load_material(name)
    plans.append(plan_gains(mat, default_method(mat)))
    p = plans[-1]
    print(f"{name:14s} {p.method:10s} alpha {p.alpha:6.1f} V/sqrt(N)  G {p.rendering_gain:.3f}  bound by {p.binding}  "
          f"headroom {p.headroom_db:.2f} dB")
plot_gain_plans(plans).savefig(out, dpi=100)
print(out)
