"""Render cork along back-and-forth strokes on the simulated display and save the figure.

Run: .venv/bin/python examples/render_cork.py     (from any folder; writes cork.png and cork-render/ there)
"""

import surfhap as sh

cork = sh.load_material("cork")
trajectory = sh.strokes(speed=0.1, load=0.3, duration=5.0, length=0.08)
result = sh.texture.render(cork, trajectory, sh.ChainConfig(method="otake2022", carrier=2000.0, seed=1))

summary = result.summary()
print(f"max |V| = {summary['max_abs_voltage']:.1f} V, clipped {summary['clipped_fraction']:.1%}")
result.plot().savefig("cork.png", dpi=110)
sh.io.write_render(result, "cork-render")
print("wrote cork.png and cork-render/")
