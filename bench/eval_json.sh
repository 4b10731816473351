# Sourced by the bench scripts: figures of a `retimegs eval` JSON read without a JSON tool.

# metric FILE KEY [SECTION]: KEY at the top level, or inside the top-level object SECTION
# ("whole", "stability"); "null" when absent or null.
metric() {
  local value
  if [ -z "${3:-}" ]; then
    value=$(grep -o "^  \"$2\": [^,]*" "$1" | head -1 | sed 's/.*: //')
  else
    value=$(sed -n "/^  \"$3\": {/,/^  }/p" "$1" | grep -o "^    \"$2\": [^,]*" | head -1 |
      sed 's/.*: //')
  fi
  echo "${value:-null}"
}

# fmt_metric VALUE DIGITS: VALUE with DIGITS decimals, or "–" for null.
fmt_metric() {
  if [ "$1" = null ]; then echo "–"; else printf "%.${2}f" "$1"; fi
}
