# Thread scaling on a many-core machine (benchmarks/README.md's sixteen-core tables):
#   bash benchmarks/threads_device.sh      (PY, N1, N2, TH, CHUNKS, OUT override the defaults below)
# Compiles the libraries side by side first (each once, in EIGENTWIST_CACHE=.devcache), then
# runs benchmarks/threads.py: the shipped Heli4 and hexapod, and the numeric-IK 6-RUS with each
# Newton chunk size of CHUNKS.
set -u
PY=${PY:-python3}; N1=${N1:-400000}; N2=${N2:-400000}; TH=${TH:-"8 16"}; CHUNKS=${CHUNKS:-"4096 8192 16384"}
OUT=${OUT:-/tmp/devout}; mkdir -p "$OUT"
nproc; lscpu | grep -E "Model name" | cut -c1-120; gcc --version | head -1
mkdir -p .devcache; chmod -R go-w .devcache; chmod 700 .devcache
export EIGENTWIST_CACHE=$PWD/.devcache PYTHONUNBUFFERED=1 PYTHONPATH=.:benchmarks
for r in hexapod heli4 examples/robots/rus6.py; do
  $PY -c "import sys, numpy as np, eigentwist; from gallery import fresh_batches; ev = eigentwist.load(sys.argv[1], backend='c', progress=None); ev.frequencies(fresh_batches(ev, np.array(ev.robot.workspace), 64, 1)[0]); print('ready', sys.argv[1])" "$r" &
done; wait; date
$PY benchmarks/threads.py --n "$N1" --repeat 3 --threads $TH --robots hexapod:none heli4:none 2>&1 | tee "$OUT/threads.txt"
for c in $CHUNKS; do
  echo "newton chunk $c"
  $PY benchmarks/threads.py --n "$N2" --repeat 3 --threads $TH --newton-chunk $c --robots examples/robots/rus6.py:none 2>&1 | tee -a "$OUT/threads.txt"
done
date
