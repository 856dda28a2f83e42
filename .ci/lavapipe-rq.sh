#!/usr/bin/env bash
# A lavapipe with ray queries (VK_KHR_ray_query: Mesa 24.1 and later) for the ray-query tests
# (tests/it/rayquery.rs), next to the system's Mesa and without replacing it.
#
#   bash .ci/lavapipe-rq.sh [DIR]        (DIR defaults to target/lavapipe-rq)
#
# On Debian 12, whose Mesa 22.3 has no ray queries, it downloads bookworm-backports' Mesa
# (mesa-vulkan-drivers, mesa-libgallium and the libdrm they need) from the Debian mirror the
# system already uses, unpacks the packages under DIR/root (nothing is installed), and writes
# DIR/env: the two variables that point one process's Vulkan loader at that lavapipe. On
# other systems it does nothing, and the tests use the system's driver. Safe to run again: an
# unpacked driver is kept.
set -euo pipefail
dir=${1:-target/lavapipe-rq}
codename=$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")
if [ "$codename" != bookworm ]; then
  echo "cuberay: not Debian 12 ($codename): the ray-query tests use the system's Vulkan driver" >&2
  exit 0
fi
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
lib=$dir/root/usr/lib/x86_64-linux-gnu
if [ ! -f "$lib/libvulkan_lvp.so" ]; then
  echo "cuberay: fetching bookworm-backports' lavapipe (ray queries) into $dir" >&2
  mkdir -p "$dir/apt/lists/partial" "$dir/debs"
  # The mirror of the system's own Debian sources (deb822 or one-line), not its security one.
  mirror=$({ cat /etc/apt/sources.list.d/*.sources /etc/apt/sources.list 2>/dev/null || true; } |
    awk '$1 == "URIs:" && $2 !~ /security/ { print $2; exit }
         $1 == "deb" && $2 !~ /security/ { print $2; exit }')
  mirror=${mirror:-http://deb.debian.org/debian}
  printf 'deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] %s bookworm-backports main\n' \
    "$mirror" >"$dir/apt/backports.list"
  apt_opts=(-o "Dir::Etc::SourceList=$dir/apt/backports.list" -o Dir::Etc::SourceParts=/dev/null
    -o "Dir::State::Lists=$dir/apt/lists" -o Debug::NoLocking=1 -o APT::Sandbox::User=root)
  apt-get "${apt_opts[@]}" update -qq
  # The backports version of a package (its version string carries "bpo12").
  backport() {
    apt-cache "${apt_opts[@]}" madison "$1" | awk -F'|' '$2 ~ /bpo12/ { gsub(/ /, "", $2); print $2; exit }'
  }
  mesa=$(backport mesa-vulkan-drivers)
  drm=$(backport libdrm2)
  [ -n "$mesa" ] && [ -n "$drm" ] || { echo "cuberay: bookworm-backports has no Mesa to fetch" >&2; exit 1; }
  (cd "$dir/debs" && apt-get "${apt_opts[@]}" download -qq "mesa-vulkan-drivers=$mesa" \
    "mesa-libgallium=$mesa" "libdrm2=$drm" "libdrm-amdgpu1=$drm" "libdrm-intel1=$drm")
  for deb in "$dir"/debs/*.deb; do dpkg-deb -x "$deb" "$dir/root"; done
fi
# The package's manifest names the library by its installed path: point it at ours.
sed "s#\"library_path\": *\"[^\"]*\"#\"library_path\": \"$lib/libvulkan_lvp.so\"#" \
  "$dir/root/usr/share/vulkan/icd.d/lvp_icd.json" >"$dir/lvp_icd.json"
printf 'LD_LIBRARY_PATH=%s\nVK_ICD_FILENAMES=%s\n' "$lib" "$dir/lvp_icd.json" >"$dir/env"
echo "cuberay: lavapipe with ray queries in $dir (variables in $dir/env)" >&2
