# The issue 31 checks on a lent GPU machine (16 cores, an NVIDIA GPU; see the tool library's
# device/README.md): `puppet animate` of the T-rex against --workers, then bench_scale's 4K
# PSD row. Run from the repository root there, with `.whl` (moderngl, glcontext, triangle,
# av, qdldl, cholespy wheels for its Python) and `.gl` (the GL loader .debs) carried. The 4K
# PSD scene is re-made from bench_import.make_psd's pixels (psd4k/s.json and the layers'
# sizes are kept here; `puppet init` needs OpenCV's contrib modules, which that machine lacks).
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
j=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json; [ -f $j ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$j
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit
export PYTHONPATH=$PWD:/tmp/site PYTHONUNBUFFERED=1
nproc; nvidia-smi -L
python3 -c "import moderngl; print(moderngl.create_standalone_context(backend='egl').info['GL_RENDERER'])"
timeout 200 python3 benchmarks/device/export_workers.py 1000:16 240:1 1000:8 1000:16
rm -rf /tmp/psd4k && cp -r benchmarks/device/psd4k /tmp/psd4k && python3 benchmarks/device/regen_psd4k.py /tmp/psd4k
timeout 240 python3 benchmarks/bench_scale.py --sizes psd4k --no-export --steps 20 --folder /tmp --timeout 100
