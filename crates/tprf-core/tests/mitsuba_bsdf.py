"""Evaluate Mitsuba 3 BSDFs for crates/tprf-core/tests/mitsuba_bsdf.rs.

    python mitsuba_bsdf.py check
    python mitsuba_bsdf.py eval CASES.jsonl

`check` exits 0 when mitsuba (its scalar_rgb variant) loads, else prints why and exits
3. `eval` reads one JSON object a line and prints one number a line: for
{"bsdf": DICT, "wo": [x, y, z], "wi": [x, y, z]} Mitsuba's `eval` (f cos(theta_wi), in
the shading frame, normal +Z; Mitsuba's `si.wi` is tprf's `wo`, its `wo` tprf's `wi`),
its red channel (the tests give grey values), for {"bsdf": DICT, "param": KEY} the
RGB parameter KEY of the loaded BSDF (`mi.traverse`), its three values on a line.
"""

import json
import os
import sys

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def load():
    if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    return mi


def main(argv):
    if argv[:1] == ["check"]:
        try:
            load()
        except Exception as e:  # noqa: BLE001
            print(f"{type(e).__name__}: {e}")
            return 3
        return 0
    mi = load()
    with open(argv[1]) as f:
        for line in f:
            case = json.loads(line)
            bsdf = mi.load_dict(case["bsdf"])
            if "param" in case:
                v = mi.traverse(bsdf)[case["param"]]
                print(" ".join(repr(float(v[i])) for i in range(3)))
                continue
            si = mi.SurfaceInteraction3f()
            si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
            si.wi = mi.Vector3f(case["wo"])
            ctx = mi.BSDFContext()
            v = bsdf.eval(ctx, si, mi.Vector3f(case["wi"]))
            print(repr(float(v[0])))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
