# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_inp_modulus.py — `volmesh mesh --modulus`: on a phantom of two blocks of
values 1000 and 2000 (uint16, background 0, --iso 500), '2*v' gives exactly two materials,
E 2000 and 4000, each on the elements of its block (the .inp's *ELASTIC, the .vtu's cell data
"modulus" and "image_mean"), and CalculiX solves the static deck where ccx is installed;
a power law with --material-bins 3 gives at most 3 materials; a bad formula, an E <= 0 and
--modulus with a format that takes neither materials nor cell data are one line, exit 2, no
file. Also the formula parser's precedence. Exit 0 pass, 1 fail, 77 skip when meshio or numpy
cannot be imported."""
import os
import re
import shutil
import subprocess
import sys
import tempfile

try:
    import meshio
    import numpy as np
except ImportError as exc:
    print(f"skipped: cannot import meshio/numpy ({exc})")
    sys.exit(77)

from harness import check, failures, need_cli, run  # noqa: E402

CLI = need_cli()
RAW = ["--raw-dims", "24x24x24", "--raw-type", "uint16", "--iso", "500", "-q"]


def elastic(path):
    """{material name: E} from the *MATERIAL / *ELASTIC pairs of an .inp."""
    lines = open(path).read().splitlines()
    out = {}
    for i, l in enumerate(lines):
        if l.upper().startswith("*MATERIAL"):
            name = re.search(r"NAME=(\w+)", l, re.I).group(1)
            k = next(k for k in range(i + 1, len(lines)) if lines[k].upper() == "*ELASTIC")
            out[name] = float(lines[k + 1].split(",")[0])
    return out


def main():
    work = tempfile.mkdtemp(prefix="modulus_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    a = np.zeros((24, 24, 24), "<u2")  # z, y, x
    a[3:21, 3:21, 3:11] = 1000
    a[3:21, 3:21, 13:21] = 2000
    open("two.raw", "wb").write(a.tobytes())
    run("mesh", "two.raw", *RAW, "--modulus", "2*v", "--deck", "static", "-o", "mod.inp")
    run("mesh", "two.raw", *RAW, "--modulus", "2*v", "-o", "mod.vtu")
    if failures:
        return 1
    mats = elastic("mod.inp")
    check(sorted(mats.values()) == [2000.0, 4000.0], f"mod.inp: moduli {mats}")
    m = meshio.read("mod.vtu")
    mod = np.asarray(m.cell_data["modulus"][0]).ravel()
    img = np.asarray(m.cell_data["image_mean"][0]).ravel()
    check(sorted(set(mod.tolist())) == [2000.0, 4000.0], f"mod.vtu: moduli {set(mod.tolist())}")
    check(np.array_equal(mod, 2 * img), "mod.vtu: modulus is not 2 * image_mean")
    cx = m.points[m.cells[0].data].mean(axis=1)[:, 0]
    check(bool(((cx < 12) == (mod == 2000)).all()), "the 1000 block's elements are not E 2000")
    if shutil.which("ccx"):
        r = subprocess.run(["ccx", "-i", "mod"], capture_output=True, text=True)
        check(r.returncode == 0 and "*ERROR" not in r.stdout,
              f"ccx mod: exit {r.returncode} {r.stdout[-400:]}")
        check(os.path.exists("mod.frd") and os.path.getsize("mod.frd") > 0, "ccx wrote no .frd")
        print("ccx solved the --modulus deck")
    else:
        print("ccx not installed: the deck is not solved (scripts/deps.sh --tests installs it)")
    run("mesh", "two.raw", *RAW, "--modulus", "6850*(0.0008*v)^1.49", "--material-bins", "3",
        "-o", "power.inp")
    pm = elastic("power.inp")
    want = sorted({6850 * (0.0008 * 1000) ** 1.49, 6850 * (0.0008 * 2000) ** 1.49})
    check(len(pm) <= 3 and len(pm) >= 2, f"power.inp: {len(pm)} materials")
    check(min(pm.values()) >= want[0] * (1 - 1e-9) and max(pm.values()) <= want[1] * (1 + 1e-9),
          f"power.inp: moduli {sorted(pm.values())} outside {want}")
    # precedence: -v^2 = -(v^2); 2^3^2 = 2^9; (1+2)*3; v/4/5 = (v/4)/5 — as materials of E > 0
    for text, value in (("0-(-v^2)+1", 1000 ** 2 + 1), ("2^3^2*v/1000", 512),
                        ("(1+2)*3*v/1000", 9), ("v/4/5", 50)):
        run("mesh", "two.raw", *RAW, "--modulus", text, "-o", "p.inp")
        got = sorted(elastic("p.inp").values())[0] if os.path.exists("p.inp") else None
        check(got is not None and abs(got - value) <= 1e-9 * value, f"'{text}': E {got}, want {value}")
        if os.path.exists("p.inp"):
            os.remove("p.inp")
    for args in (["--modulus", "2*"], ["--modulus", "2*x"], ["--modulus", "(v"],
                 ["--modulus", "v-5000"], ["--modulus", "v", "--materials", "none.csv"],
                 ["--material-bins", "4"], ["--modulus", "v", "--material-bins", "0"]):
        r = run("mesh", "two.raw", *RAW, *args, "-o", "bad.inp", expect=2)
        check(len(r.stderr.strip().splitlines()) == 1, f"{args}: stderr {r.stderr!r}")
        check(not os.path.exists("bad.inp"), f"{args}: bad.inp written")
    r = run("mesh", "two.raw", *RAW, "--modulus", "v", "-o", "bad.msh", expect=2)
    check(not os.path.exists("bad.msh"), "--modulus with .msh: file written")
    print("modulus: %d failures" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
