#!/usr/bin/env bash
# Run on a build machine (Debian 12): downloads into .gpu/ the Debian packages that the lean GPU
# build (-DRETIMEGS_GPU_ONLY=ON) needs, for scripts/gpu_check.sh on a bare GPU machine, which has
# no package manager and no network. Prints their total size: the files brought to that machine
# may take 64 MiB in all (DESIGN.md §3).
#
#   bash scripts/gpu_bundle.sh [--panoptic]
#
# --panoptic adds what scripts/gpu_panoptic.sh needs there, 27.5 MiB: the lean app's packages
# (16.0 MiB: OpenCV's core, imgproc and video with the libraries they load, libpng, libjpeg, zlib,
# spdlog, CLI11; not imgcodecs, videoio or contrib, which load GDAL, FFmpeg and GStreamer: 46 MB
# more) and .gpu/panoptic/ (11.5 MiB): the clip's JPEGs and masks, and the points and scene.json
# of the scene bench/panoptic.sh prepares here (in WORK, bench/results/panoptic/ unless set; it
# is imported and prepared first when it is not), so that both runs start from the same points.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
panoptic=0
[[ ${1:-} == --panoptic ]] && panoptic=1

packages=(
  libeigen3-dev                 # header-only
  libfmt-dev libfmt9            # fmt's headers and CMake files; the shared library core links
  libgtest-dev libgmock-dev     # static libraries; GTest's CMake files refer to gmock's too
  nlohmann-json3-dev            # header-only
  libnanoflann-dev              # header-only (train's nearest neighbours)
)
if ((panoptic)); then
  packages+=(
    # OpenCV's headers, and its libraries with those they load (ldd), for -DRETIMEGS_GPU_APP=ON
    libopencv-core-dev libopencv-imgproc-dev libopencv-video-dev
    libopencv-core406 libopencv-imgproc406 libopencv-video406 libopencv-calib3d406
    libopencv-dnn406 libopencv-features2d406 libopencv-flann406 libprotobuf32 libtbb12 libblas3
    liblapack3 libgfortran5 libquadmath0 libglx0 libglvnd0 libx11-6 libxcb1 libxau6 libxdmcp6
    libbsd0 libmd0
    libpng-dev libpng16-16 zlib1g-dev zlib1g libjpeg62-turbo-dev libjpeg62-turbo  # media
    libspdlog-dev libspdlog1.10 libcli11-dev  # train's log; the app's argument parser
  )
fi

bundle="$root/.gpu"
rm -rf "$bundle"
mkdir -p "$bundle"
# As root, apt's download sandbox user cannot write into the checkout; the files are only read.
(cd "$bundle" && apt-get download -q -o APT::Sandbox::User=root "${packages[@]}")

if ((panoptic)); then
  data=${DATA:-$root/../shared/data/panoptic-basketball}
  work=${WORK:-$root/bench/results/panoptic}
  bin="$root/build/apps/retimegs"
  [ -x "$bin" ] || "$root/scripts/setup.sh"
  scene="$work/scene"
  [ -f "$scene/scene.json" ] || "$bin" import panoptic --in "$data" --out "$scene"
  # The points (COLMAP and the visual hull, which the GPU machine has not); the flows it computes.
  "$bin" prepare --scene "$scene"
  mkdir -p "$bundle/panoptic/data"
  cp -r "$data/ims" "$data/seg" "$data/train_meta.json" "$data/test_meta.json" \
    "$bundle/panoptic/data/"
  cp -r "$scene/points" "$scene/scene.json" "$bundle/panoptic/"
fi

bytes=$(du -cb "$bundle"/*.deb | tail -n 1 | cut -f 1)
echo "gpu_bundle: ${#packages[@]} packages in .gpu/, $((bytes / 1024)) KiB"
if ((panoptic)); then
  scene_bytes=$(du -sb "$bundle/panoptic" | cut -f 1)
  bytes=$((bytes + scene_bytes))
  echo "gpu_bundle: the Panoptic clip in .gpu/panoptic/, $((scene_bytes / 1024)) KiB;" \
    "$((bytes / 1024)) KiB in all"
fi
if ((bytes > 64 * 1024 * 1024)); then
  echo "gpu_bundle: more than the 64 MiB a bare GPU machine may be brought" >&2
  exit 1
fi
