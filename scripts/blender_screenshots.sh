#!/usr/bin/env bash
# Screenshots of the Blender add-on in Blender's own user interface, for the guide (docs/blender.md):
#   blender_frame_in_blender.png  the whole window: 3D viewport, refrakt's frame in the image
#                                 editor, Object ▸ refrakt of the lens, Render ▸ refrakt
#   blender_panel.png             Render Properties ▸ refrakt, every subpanel open
#   blender_object_panel.png      Object Properties ▸ refrakt (a Luneburg lens index field)
#   blender_progress.png          Render ▸ refrakt while refrakt renders (progress, cancel)
# or, with SCREENSHOTS=engine, those of scripts/blender_engine_screenshots.py (F12 with the
# refrakt render engine, its passes in the compositor, the viewport in Rendered mode):
#   blender_engine.png, blender_engine_viewport.png, blender_engine_passes.png
# A maintainer tool, not part of CI. Run as root (debootstrap, chroot, mounts), with the network
# to deb.debian.org, from anywhere in the repository:
#
#   REFRAKT_BIN=/path/to/refrakt scripts/blender_screenshots.sh [OUTDIR]   (default docs/images)
#
# The add-on is an extension (Blender 4.2 or later) and Debian bookworm has Blender 3.4, so this
# sets up a Debian trixie chroot (Blender 4.3) in $TRIXIE (default /tmp/trixie) with Xvfb, xwd,
# ImageMagick and Mesa's software OpenGL (llvmpipe, OpenGL 4.5) and Vulkan (lavapipe, for
# refrakt); nothing from trixie is installed on the host. It then runs
# scripts/blender_screenshots.py in Blender's user interface under xvfb-run and copies the PNGs
# to OUTDIR. Each setup step is skipped when already done; the mounts it makes are undone at exit.
#
# REFRAKT_BIN: a refrakt that renders glTF (default: target/release/refrakt); it is copied into
# the chroot (a plain glibc x86-64 executable). The render is tiny (320×180, a 96³ volume,
# 20k photons, two frames): about a minute on two CPU cores.
set -euo pipefail
cd "$(dirname "$0")/.."
REPO=$PWD
OUTDIR=$(realpath -m "${1:-docs/images}")
TRIXIE=${TRIXIE:-/tmp/trixie}
MIRROR=${MIRROR:-http://deb.debian.org/debian}
REFRAKT_BIN=${REFRAKT_BIN:-$REPO/target/release/refrakt}
SCREEN="1600x1200x24"  # the layout in blender_screenshots.py is made for this size
case "${SCREENSHOTS:-addon}" in
  addon) SCRIPT=blender_screenshots.py; NAMES="blender_frame_in_blender blender_panel blender_object_panel blender_progress" ;;
  engine) SCRIPT=blender_engine_screenshots.py; NAMES="blender_engine blender_engine_viewport blender_engine_passes" ;;
  *) echo "blender_screenshots: SCREENSHOTS is addon or engine, not ${SCREENSHOTS}" >&2; exit 1 ;;
esac
PACKAGES="blender python3-numpy xvfb xauth x11-apps imagemagick libgl1-mesa-dri libglx-mesa0 mesa-vulkan-drivers libvulkan1"

say() { echo "blender_screenshots: $*" >&2; }
die() { say "$*"; exit 1; }

[ "$(id -u)" = 0 ] || die "run as root (debootstrap, chroot and mounts need it)"
[ -x "$REFRAKT_BIN" ] || die "no refrakt at $REFRAKT_BIN (build it, or set REFRAKT_BIN)"
"$REFRAKT_BIN" render --help 2>/dev/null | grep -qi gltf \
  || die "$REFRAKT_BIN cannot render glTF (the add-on exports .glb): set REFRAKT_BIN to a refrakt with glTF support"

# 1. The trixie chroot.
if [ ! -x "$TRIXIE/usr/bin/apt-get" ]; then
  command -v debootstrap >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
  say "debootstrap trixie into $TRIXIE"
  debootstrap --variant=minbase trixie "$TRIXIE" "$MIRROR"
fi
cp /etc/resolv.conf "$TRIXIE/etc/resolv.conf"

# 2. Mounts (only those missing; those made here are undone at exit).
MOUNTED=()
cleanup() {
  for ((i = ${#MOUNTED[@]} - 1; i >= 0; i--)); do umount "${MOUNTED[i]}" || say "could not unmount ${MOUNTED[i]}"; done
}
trap cleanup EXIT
mount_once() {  # mount_once TARGET MOUNT-ARGS...
  local target=$1; shift
  mkdir -p "$target"
  if ! mountpoint -q "$target"; then
    mount "$@" "$target"
    MOUNTED+=("$target")
  fi
}
mount_once "$TRIXIE/proc" -t proc proc
mount_once "$TRIXIE/sys" -t sysfs sys
mount_once "$TRIXIE/dev/shm" -t tmpfs -o mode=1777 shm
mount_once "$TRIXIE/dev/pts" -t devpts -o newinstance,ptmxmode=0666 devpts
mount_once "$TRIXIE$REPO" --bind "$REPO"  # the scripts and the add-on, at the same path

in_chroot() { chroot "$TRIXIE" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 "$@"; }

# 3. Packages.
# shellcheck disable=SC2086
if ! in_chroot dpkg-query -W $PACKAGES >/dev/null 2>&1; then
  say "installing $PACKAGES in the chroot"
  in_chroot DEBIAN_FRONTEND=noninteractive apt-get update -qq
  # shellcheck disable=SC2086
  in_chroot DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $PACKAGES >/dev/null
fi

# 4. refrakt.
mkdir -p "$TRIXIE/opt/refrakt"
cmp -s "$REFRAKT_BIN" "$TRIXIE/opt/refrakt/refrakt" || cp "$REFRAKT_BIN" "$TRIXIE/opt/refrakt/refrakt"
in_chroot XDG_RUNTIME_DIR=/tmp /opt/refrakt/refrakt info | sed -n 1p >&2

# 5. Blender, with its user interface on a virtual display.
SHOTS=/tmp/refrakt-screenshots  # paths inside the chroot
rm -rf "$TRIXIE$SHOTS" "$TRIXIE/tmp/refrakt-screenshots-home" "$TRIXIE/tmp/refrakt-screenshots-xdg"
install -d -m 700 "$TRIXIE/tmp/refrakt-screenshots-xdg"
say "$(in_chroot blender --version 2>/dev/null | head -1): running scripts/$SCRIPT"
in_chroot HOME=/tmp/refrakt-screenshots-home XDG_RUNTIME_DIR=/tmp/refrakt-screenshots-xdg LIBGL_ALWAYS_SOFTWARE=1 \
  timeout 1200 xvfb-run -a -s "-screen 0 $SCREEN" \
  blender --factory-startup --python "$REPO/scripts/$SCRIPT" -- "$SHOTS" \
  --refrakt /opt/refrakt/refrakt --work /tmp/refrakt-demo

mkdir -p "$OUTDIR"
for name in $NAMES; do
  [ -f "$TRIXIE$SHOTS/$name.png" ] || die "Blender wrote no $name.png"
  cp "$TRIXIE$SHOTS/$name.png" "$OUTDIR/$name.png"
  say "$OUTDIR/$name.png ($(du -k "$OUTDIR/$name.png" | cut -f1) KiB)"
done
