#!/bin/sh
# Regenerates DejaVuSans-fts.ttf, the font PNG plots are drawn with (SVG
# plots name `sans-serif` and leave the font to the viewer): DejaVu Sans
# (Debian's fonts-dejavu-core 2.37) cut to Basic Latin, Latin-1, Greek and
# the few symbols fts writes, without hinting. Needs fonttools (pip).
set -e
cd "$(dirname "$0")"
pyftsubset /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf \
  --unicodes="U+0020-007E,U+00A0-00FF,U+0370-03FF,U+2010-2027,U+2030-203A,U+2070-209F,U+2190-2193,U+2202,U+2206,U+2211,U+2212,U+221A,U+221E,U+2248,U+2260,U+2264,U+2265,U+22C5" \
  --no-hinting --desubroutinize --output-file=DejaVuSans-fts.ttf
