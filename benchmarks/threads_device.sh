# Thread scaling on a many-core machine (benchmarks/README.md's sixteen-core tables):
#   bash benchmarks/threads_device.sh      (PY, N1, N2, TH, PROCS, CHUNKS, OUT override the defaults below)
# To spend the machine's minutes on compiling only, generate the gallery robots' sources here first
# (EIGENTWIST_CACHE=$PWD/.devcache, load examples/robots/rus6.py with backend="c", then delete
# .devcache/*.so* and *.lock) and carry .devcache along.
# Compiles the libraries side by side first (each once, in EIGENTWIST_CACHE=.devcache), then, in
# order of what a cut-off run loses last: the hexapod's threads (benchmarks/threads.py), the same
# counts as independent processes (benchmarks/processes.py: the machine's own bound), the
# hexapod's threads again with glibc's allocator keeping its freed memory (no page faults from
# returned blocks), the numeric-IK 6-RUS's threads for each Newton chunk size of CHUNKS and its
# processes, and the Heli4's threads.
set -u
PY=${PY:-python3}; N1=${N1:-400000}; N2=${N2:-200000}; TH=${TH:-"8 16"}; PROCS=${PROCS:-"8 16"}
CHUNKS=${CHUNKS:-"8192"}
OUT=${OUT:-/tmp/devout}; mkdir -p "$OUT"
nproc; lscpu | grep -E "Model name" | cut -c1-120; gcc --version | head -1
mkdir -p .devcache; chmod -R go-w .devcache; chmod 700 .devcache
export EIGENTWIST_CACHE=$PWD/.devcache PYTHONUNBUFFERED=1 PYTHONPATH=.:benchmarks
for r in hexapod heli4 examples/robots/rus6.py; do
  $PY -c "import sys, numpy as np, eigentwist; from gallery import fresh_batches; ev = eigentwist.load(sys.argv[1], backend='c', progress=None); ev.frequencies(fresh_batches(ev, np.array(ev.robot.workspace), 64, 1)[0]); print('ready', sys.argv[1])" "$r" &
done; wait; date
$PY benchmarks/threads.py --n "$N1" --repeat 3 --threads $TH --robots hexapod:none 2>&1 | tee "$OUT/threads.txt"
$PY benchmarks/processes.py --n "$N1" --repeat 3 --procs $PROCS --robots hexapod:none 2>&1 | tee "$OUT/processes.txt"
echo "allocator keeps freed memory" | tee -a "$OUT/threads.txt"
MALLOC_TRIM_THRESHOLD_=4000000000 MALLOC_MMAP_THRESHOLD_=4000000000 MALLOC_TOP_PAD_=536870912 \
  $PY benchmarks/threads.py --n "$N1" --repeat 3 --threads $TH --robots hexapod:none 2>&1 | tee -a "$OUT/threads.txt"
date
for c in $CHUNKS; do
  echo "newton chunk $c" | tee -a "$OUT/threads.txt"
  $PY benchmarks/threads.py --n "$N2" --repeat 3 --threads $TH --newton-chunk $c --robots examples/robots/rus6.py:none 2>&1 | tee -a "$OUT/threads.txt"
done
$PY benchmarks/processes.py --n "$N2" --repeat 3 --procs $PROCS --robots examples/robots/rus6.py:none 2>&1 | tee -a "$OUT/processes.txt"
$PY benchmarks/threads.py --n "$N1" --repeat 3 --threads $TH --robots heli4:none 2>&1 | tee -a "$OUT/threads.txt"
date
