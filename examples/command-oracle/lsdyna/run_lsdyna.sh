#!/bin/sh
# Wrapper for the lsdyna-headrest catalogue entry (docs/external-solvers.md).
# Runs in alcove's working directory, which holds headrest.k (the rendered template),
# trajectory.csv and params.json; must leave forces.csv behind and exit 0, or exit non-zero.
#
# Environment (set in the catalogue entry's env):
#   LSDYNA             the solver executable (e.g. /opt/lsdyna/lsdyna_smp_d_R13)
#   LSDYNA_NCPU        threads (default 2)
#   MODEL_DIR          folder with headrest_model.k and head_model.k
#   HEAD_WRENCH_EXTRACT  site-specific command that reads LS-DYNA's output here and writes
#                      head_wrench.csv: t,fx,fy,fz,mx,my,mz, contact force on the head in the
#                      model frame (= H) and its moment about the model origin, model units
#                      (e.g. summing NCFORC nodal forces f_i and r_i x f_i with lasso-python
#                      or an LS-PrePost script, as the paper's MATLAB tool chain did)
set -eu
cp "$MODEL_DIR/headrest_model.k" "$MODEL_DIR/head_model.k" .
"$LSDYNA" i="$ALCOVE_INPUT" ncpu="${LSDYNA_NCPU:-2}" > lsdyna.log 2>&1 || {
    tail -n 20 lsdyna.log >&2; echo "LS-DYNA exited with an error" >&2; exit 1; }
# LS-DYNA can exit with 0 after an error termination: check the banner.
grep -q "N o r m a l    t e r m i n a t i o n" lsdyna.log || {
    tail -n 20 lsdyna.log >&2; echo "LS-DYNA did not terminate normally" >&2; exit 1; }
$HEAD_WRENCH_EXTRACT
"${PYTHON:-python3}" "$(dirname "$0")/to_forces_csv.py" head_wrench.csv \
    --trajectory "$ALCOVE_TRAJECTORY" --out "$ALCOVE_OUTPUT" --length-unit mm
