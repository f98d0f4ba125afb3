#!/usr/bin/env bash
# check_isa_isolation.sh BINARY: the portable binary's instructions beyond x86-64 (VEX/EVEX:
# AVX, AVX2, FMA, AVX-512; BMI, LZCNT, MOVBE) are all in the kernel variants' functions (names
# ending .<lib>_isa_x86_64_v3 / _v4, toolchain/springbok_isa.cmake), and there are some: code
# that runs before the level is chosen, or at the baseline, cannot fault on an older CPU.
# (TZCNT is not counted: GCC's baseline code has it as REP BSF, which older CPUs run as BSF.)
set -euo pipefail
bin=$1
objdump -d --no-show-raw-insn "$bin" | awk '
  /^[0-9a-f]+ <.*>:$/ { fn = $2; next }
  NF >= 2 && $1 ~ /:$/ {
    op = $2
    if (op ~ /^(v[a-z]|kmov|kor|kand|knot|kxor|kshift|kunpck|ktest)/ || op ~ /^(shlx|shrx|sarx|rorx|andn|bextr|blsi|blsr|blsmsk|bzhi|pdep|pext|mulx|lzcnt|movbe)[bwlq]?$/) {
      if (fn ~ /_isa_x86_64_v[34]>:$/) variant++
      else { baseline++; if (baseline <= 5) print "check_isa_isolation: beyond x86-64 outside the kernels: " fn " " op > "/dev/stderr" }
    }
  }
  END {
    printf "check_isa_isolation: %d instructions beyond x86-64 in the kernel variants, %d elsewhere\n", variant, baseline
    exit (baseline > 0 || variant == 0) ? 1 : 0
  }'
