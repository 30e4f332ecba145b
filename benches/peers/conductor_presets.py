#!/usr/bin/env python3
"""Prints the RGB complex index of refraction (eta, k) of the conductor presets vkpath has (CONDUCTOR_PRESETS in src/scene/mod.rs).

The values are Mitsuba 3's: its `conductor` plugin with `material = "Au"` (and "Ag", "Cu", "Al") reads
spectral n, k tables shipped in the mitsuba package (mitsuba/data/ior/*.spd, from the luxpop.com database)
and, in an RGB variant, reduces them to linear sRGB. Reading them back from Mitsuba itself keeps the two
renderers' metals the same in benches/peers. Run with the venv of benches/peers/setup.sh:

    benches/peers/.venv/bin/python benches/peers/conductor_presets.py
"""

import mitsuba as mi

PRESETS = {"gold": "Au", "silver": "Ag", "copper": "Cu", "aluminium": "Al"}


def main() -> None:
    mi.set_variant("scalar_rgb")
    print(f"# mitsuba {mi.__version__}, scalar_rgb")
    for name, symbol in PRESETS.items():
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": symbol}))
        eta = [float(c) for c in params["eta.value"]]
        k = [float(c) for c in params["k.value"]]
        print(f"{name} ({symbol}): eta = {eta}, k = {k}")


if __name__ == "__main__":
    main()
