#!/usr/bin/env bash
# H200 host, stop 45 (issue 27): run25.sh with this stop's last build (S45B = abb4638:
# run28's S45A plus the voxel map's runs of a 256th of a thread's share; the same
# structure as e763231's) against stop 43's (FINAL = 003f31a) and the issue's start
# (START = e763231). CPU only; carried: .devbin, .models.tar.xz.
NEW=s45b exec bash "$(dirname "$0")/run25.sh"
