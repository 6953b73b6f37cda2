#!/usr/bin/env bash
# Run CMD inside user-mode-linux with real vcan0/vcan1 (where the kernel has no CAN):
#   bash ci/uml-vcan.sh python3 -m pytest -q -m socketcan
# The runner ships in the package (hil/bus/uml/uml-vcan.sh); this is `wheelleg vcan uml -- CMD`
# for a checkout, with the same exit status.
exec python3 -m wheelleg.hil.cli vcan uml -- "$@"
