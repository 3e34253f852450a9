# Sourced by the device scripts (gpu_prior.sh, gpu_bench.sh) from the repository root: makes `svbrdf.*` importable
# without pip on a bare GPU machine (a folder of links: the device has no network and no build of the package) and
# installs the wheels of a carried `.whl/` folder first (kornia, OpenImageIO, isal: the device lacks them; the prior needs
# neither; WHEELS names another folder, e.g. an empty one to install none). Sets PYTHONPATH and PYTHONUNBUFFERED;
# calls `say` (defined by the caller) on failure and returns 1.
_gpu_site="$(mktemp -d)"
mkdir -p "$_gpu_site/svbrdf"
for _part in runtime trainer export models; do ln -s "$(pwd)/$_part" "$_gpu_site/svbrdf/$_part"; done
export PYTHONPATH="$_gpu_site${PYTHONPATH:+:$PYTHONPATH}"
_gpu_wheels="${WHEELS:-.whl}"
if compgen -G "$_gpu_wheels/*.whl" > /dev/null; then
    "${PYTHON:-python3}" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site \
        "$_gpu_wheels"/*.whl || { say "wheel install failed"; return 1; }
    export PYTHONPATH="/tmp/site:$PYTHONPATH"
fi
export PYTHONUNBUFFERED=1
