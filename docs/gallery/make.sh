#!/bin/sh
# Regenerate the README gallery: the engine (seed Fig. 6) and frog (seed Fig. 7) sweeps at publication
# size, supersampled, as labelled contact sheets plus one full-size frame each. Needs the CT data in
# ../shared/volumes (not part of the repository). Run from the crate root:
#
#     sh docs/gallery/make.sh
#
# Frames go to target/gallery (not committed); the sheets and hero frames to docs/gallery.
set -eu
cd "$(dirname "$0")/../.."
# METAMER=path/to/metamer uses that binary instead of building one.
if [ -z "${METAMER:-}" ]; then cargo build --release --quiet; fi
bin=${METAMER:-target/release/metamer}
out=target/gallery
$bin render volumes/engine.toml --frames 12 --size 1024 --ss 2 -o "$out/engine" \
    --contact-sheet docs/gallery/engine_sheet.png --title "GE engine CT sweep (volumes/engine.toml; seed Fig. 6 is docs/figures/fig6_engine.png): hide → split → glow"
cp "$out/engine/frame_0006.png" docs/gallery/engine_frame.png
$bin render volumes/frog.toml --frames 12 --size 1024 --ss 2 -o "$out/frog" \
    --contact-sheet docs/gallery/frog_sheet.png --title "Whole Frog tissue labels (seed Fig. 7): daylight → reveal → fluorescent"
cp "$out/frog/frame_0006.png" docs/gallery/frog_frame.png
$bin render --frames 12 --size 1024 --ss 2 -o "$out/builtin" \
    --contact-sheet docs/gallery/builtin_sheet.png --title "embedded default (generated engine-like volume)"
