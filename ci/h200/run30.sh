#!/usr/bin/env bash
# H200 host, stop 45 (issue 27): run25.sh with this stop's last build (S45C = d60807a:
# run29's S45B plus the growth's answers known without a query, from the two exit boxes
# grown last and the faces' walls; the same structure as e763231's) against stop 43's
# (FINAL = 003f31a) and the issue's start (START = e763231). CPU only; carried: .devbin,
# .models.tar.xz.
NEW=s45c exec bash "$(dirname "$0")/run25.sh"
