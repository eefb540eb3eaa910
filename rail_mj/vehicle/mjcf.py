"""A vehicle's MJCF files: `<name>.xml`, a `scene.xml` with track and lights, the wheel mesh in
`assets/`; checked to read back to the very model the runner steps.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from rail_mj.files import staged
from rail_mj.layout import Layout
from rail_mj.vehicle.looks import RAIL_HEAD_WIDTH
from rail_mj.vehicle.spec import compiled

SCENE_TEMPLATE = """\
<mujoco model="{name} scene">
  <include file="{name}.xml"/>

  <statistic center="0 0 1" extent="{extent:g}"/>

  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="120" elevation="-20"/>
  </visual>

  <asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="512" height="3072"/>
    <texture type="2d" name="ballast" builtin="checker" mark="edge" rgb1="0.35 0.33 0.3" rgb2="0.3 0.28 0.25"
      markrgb="0.5 0.5 0.5" width="300" height="300"/>
    <material name="ballast" texture="ballast" texuniform="true" texrepeat="5 5" reflectance="0"/>
    <material name="steel" rgba="0.75 0.75 0.78 1" specular="0.8"/>
  </asset>

  <worldbody>
    <light name="sun" pos="0 0 20" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="0 0 0.05" pos="0 0 {floor_z:g}" material="ballast"/>
    <!-- Rail heads centred on the contact points (y = +/- b), top at z = 0. -->
    <geom name="left_rail" type="box" size="{rail_half_length:g} {rail_half_width:g} 0.08"
      pos="0 {b:g} -0.08" material="steel"/>
    <geom name="right_rail" type="box" size="{rail_half_length:g} {rail_half_width:g} 0.08"
      pos="0 {neg_b:g} -0.08" material="steel"/>
  </worldbody>
</mujoco>
"""


def scene_xml(layout: Layout) -> str:
    xs = layout.wheelset_x
    length = max(xs) - min(xs) + 10.0
    b = layout.wheelset.contact_half_spacing
    return SCENE_TEMPLATE.format(
        name=layout.name,
        extent=length,
        floor_z=-0.16,
        rail_half_length=length,
        rail_half_width=RAIL_HEAD_WIDTH / 2,
        b=b,
        neg_b=-b,
    )


def generated_files(layout: Layout) -> dict[str, bytes]:
    """Every file `generate` writes, relative to the output folder."""
    spec, model = compiled(layout)  # to_xml needs a compiled spec; also proves the model is valid
    xml = spec.to_xml()
    # MuJoCo's writer keeps 6 significant figures (every number went in through _g6) and
    # writes as 0 any entry of a numeric below 1e-12 of its largest: check that the MJCF
    # reads back to the very model the runner steps, numbers and all.
    written = mujoco.MjModel.from_xml_string(xml, spec.assets)
    if not np.array_equal(written.numeric_data, model.numeric_data):
        k = int(np.flatnonzero(written.numeric_data != model.numeric_data)[0])
        raise ValueError(
            f"{layout.source}: the written MJCF would not read back to the model (numeric entry {k}: "
            f"{model.numeric_data[k]!r} written as {written.numeric_data[k]!r}); a bug in rail-mj"
        )
    files = {f"{layout.name}.xml": xml.encode(), "scene.xml": scene_xml(layout).encode()}
    for name, data in spec.assets.items():
        files[f"assets/{name}"] = bytes(data)
    return files


def generate(layout: Layout, out_dir: str | Path) -> list[Path]:
    """Write `<name>.xml`, `scene.xml` and `assets/` into `out_dir`.

    The files are written to temporary names and renamed into place together, so a
    failure never leaves a half-written file or half a model.
    """
    files = generated_files(layout)
    written = [Path(out_dir) / rel for rel in files]
    with staged(written) as temps:
        for tmp, data in zip(temps, files.values()):
            tmp.write_bytes(data)
    return written
