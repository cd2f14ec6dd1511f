#!/usr/bin/env bash
# H200 host, stop 45 (issue 27): run25.sh with this stop's build (S45A = e24be3d: a
# triangle's candidate cells tested four at a time with AVX, a node frame's cell boxes
# worked out once, the top level's pairs sorted serially below 1 M, a parallel split's
# parts appended part by part, the cell table written once, a node's binning straight into
# its bit set; the same structure as e763231's) against stop 43's (FINAL = 003f31a) and
# the issue's start (START = e763231). CPU only; carried: .devbin, .models.tar.xz.
NEW=s45a exec bash "$(dirname "$0")/run25.sh"
