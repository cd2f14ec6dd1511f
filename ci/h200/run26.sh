#!/usr/bin/env bash
# H200 host, stop 44 (issue 27): run25.sh once more with this stop's final build code
# (S44B = bad44fa: run25's S44 plus 32-byte leaf cells in the runs; the same structure as
# e763231's) against stop 43's (FINAL = 003f31a) and the issue's start (START = e763231).
# CPU only; carried: .devbin, .models.tar.xz.
NEW=s44b exec bash "$(dirname "$0")/run25.sh"
