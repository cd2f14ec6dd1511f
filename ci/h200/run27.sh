#!/usr/bin/env bash
# H200 host, stop 44 (issue 27): run25.sh with this stop's last build (S44C = 976be45:
# run26's S44B plus the mean growth's logarithms of the grown cells only and the query box
# built by selection; the same structure as e763231's) against stop 43's (FINAL = 003f31a)
# and the issue's start (START = e763231). CPU only; carried: .devbin, .models.tar.xz.
NEW=s44c exec bash "$(dirname "$0")/run25.sh"
