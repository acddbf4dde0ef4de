#!/usr/bin/env bash
# Prints the Debian packages that provide the shared libraries BINARY... link directly (their
# NEEDED entries), one per line, sorted. apt-get pulls in what those libraries need themselves.
# docker/Dockerfile's build stage runs it on the two binaries; the runtime stage installs the list.
set -euo pipefail
[ $# -gt 0 ] || { echo "usage: $0 BINARY..." >&2; exit 2; }

# dpkg registers a library under /lib or /usr/lib (merged /usr makes both paths work at run time).
owner() {
  local path=$1 real candidate found
  real=$(readlink -f "$path")
  for candidate in "$path" "$real" "/usr${path}" "/usr${real}" "${path#/usr}" "${real#/usr}"; do
    if found=$(dpkg-query -S "$candidate" 2>/dev/null) && [ -n "$found" ]; then
      found=${found%%$'\n'*}   # first line: "package[:arch]: path"
      echo "${found%%:*}"
      return 0
    fi
  done
  return 1
}

for binary in "$@"; do
  ldd_out=$(ldd "$binary")
  for soname in $(readelf -d "$binary" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    path=$(awk -v so="$soname" '$1 == so && $2 == "=>" { print $3 }' <<<"$ldd_out")
    if [ -z "$path" ] || ! pkg=$(owner "$path") || [ -z "$pkg" ]; then
      echo "runtime-packages: no Debian package provides $soname (needed by $binary)" >&2
      exit 1
    fi
    echo "$pkg"
  done
done | sort -u
