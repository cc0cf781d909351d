#!/usr/bin/env python3
"""Checks that a build for baseline x86-64 (`-C target-cpu=x86-64`) has no instruction beyond
SSE2 in the project's own code: the functions of the given binaries whose (demangled) names
are in the `penumbra` crate, disassembled with objdump, must use no SSE3, SSSE3, SSE4.1,
SSE4.2, POPCNT, AVX or FMA instruction. (Dependencies that choose their instructions at run
time, such as memchr, and the reference tracer's AVX box test, which is chosen at run time
too, are left out: they are reached only on CPUs that have them.)

    python3 tools/check_baseline_isa.py target/x86-64-baseline/release/deps/determinism-*

Exits 1 and names each function and instruction found.
"""
import re
import subprocess
import sys

# Mnemonics beyond SSE2 (prefix match where a family shares a stem).
BEYOND_SSE2 = [
    # SSE3
    "addsubp", "haddp", "hsubp", "movshdup", "movsldup", "movddup", "lddqu",
    # SSSE3
    "pshufb", "palignr", "pabsb", "pabsw", "pabsd", "phaddw", "phaddd", "phsubw", "phsubd",
    "pmaddubsw", "pmulhrsw", "psignb", "psignw", "psignd",
    # SSE4.1
    "blendp", "blendvp", "pblendvb", "pblendw", "roundp", "rounds", "dppd", "dpps", "insertps",
    "extractps", "pextrb", "pextrd", "pextrq", "pinsrb", "pinsrd", "pinsrq", "pminsb", "pminsd",
    "pminuw", "pminud", "pmaxsb", "pmaxsd", "pmaxuw", "pmaxud", "pmulld", "pmuldq", "pmovsx",
    "pmovzx", "packusdw", "ptest", "pcmpeqq", "mpsadbw", "phminposuw", "movntdqa",
    # SSE4.2, POPCNT
    "pcmpgtq", "pcmpestr", "pcmpistr", "crc32", "popcnt",
    # FMA (and any other VEX-encoded instruction: they start with v)
    "vfmadd", "vfmsub", "vfnmadd", "vfnmsub",
]
# BMI and LZCNT, matched whole (`andnps` and `pextrw` are SSE/SSE2). `tzcnt` is not here: the
# compiler emits it as `rep bsf` for baseline x86-64, which older CPUs run as `bsf`.
BMI = {"lzcnt", "andn", "bextr", "blsi", "blsr", "blsmsk", "bzhi", "shlx", "shrx", "sarx",
       "pdep", "pext", "rorx", "mulx"}
VEX = re.compile(r"^v[a-z]")
# Functions that pick their instructions at run time (cpu feature detection).
RUNTIME_CHOSEN = ("avx",)

HEADER = re.compile(r"^[0-9a-f]+ <(.*)>:$")
INSN = re.compile(r"^\s+[0-9a-f]+:\s+([a-z][a-z0-9.]*)")


def check(path):
    out = subprocess.run(["objdump", "-d", "--no-show-raw-insn", "-C", path],
                         capture_output=True, text=True, check=True).stdout
    bad, func, ours = [], None, False
    for line in out.splitlines():
        m = HEADER.match(line)
        if m:
            func = m.group(1)
            ours = "penumbra::" in func and not any(r in func.lower() for r in RUNTIME_CHOSEN)
            continue
        if not ours:
            continue
        m = INSN.match(line)
        if m:
            op = m.group(1)
            if VEX.match(op) or op in BMI or any(op.startswith(p) for p in BEYOND_SSE2):
                bad.append(f"{path}: {func}: {op}")
    return bad


def main():
    paths = [p for p in sys.argv[1:] if not p.endswith(".d")]
    if not paths:
        sys.exit("check_baseline_isa: no binary given")
    bad = []
    for p in paths:
        with open(p, "rb") as f:
            if f.read(4) != b"\x7fELF":
                continue
        bad += check(p)
    if bad:
        print("\n".join(sorted(set(bad))[:200]))
        sys.exit(f"{len(set(bad))} instructions beyond baseline x86-64 in penumbra's own code")
    print(f"baseline x86-64: no instruction beyond SSE2 in penumbra's code ({len(paths)} binaries)")


if __name__ == "__main__":
    main()
