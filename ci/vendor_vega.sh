#!/usr/bin/env bash
# Build vendor/dvc_plots_offline.html: DVC's plots page template with Vega, Vega-Lite and Vega-Embed inlined
# (BSD-3-Clause, their licence banners kept), so that `dvc plots show` draws its charts with no network
# (.dvc/config: plots.html_template). DVC's own template loads the three from cdn.jsdelivr.net.
# Run once per version bump; commit the result.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
VEGA=5.30.0 VEGA_LITE=5.21.0 VEGA_EMBED=6.26.0
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
npm pack --silent "vega@$VEGA" "vega-lite@$VEGA_LITE" "vega-embed@$VEGA_EMBED" >/dev/null
mkdir vega vega-lite vega-embed
tar xzf "vega-$VEGA.tgz" -C vega && tar xzf "vega-lite-$VEGA_LITE.tgz" -C vega-lite
tar xzf "vega-embed-$VEGA_EMBED.tgz" -C vega-embed
out="$root/vendor/dvc_plots_offline.html"
{
  printf '<!DOCTYPE html>\n<html>\n<head>\n{refresh_tag}\n<title>DVC Plot (offline: vega %s, vega-lite %s, vega-embed %s inlined)</title>\n' "$VEGA" "$VEGA_LITE" "$VEGA_EMBED"
  for js in vega/package/build/vega.min.js vega-lite/package/build/vega-lite.min.js vega-embed/package/build/vega-embed.min.js; do
    printf '<script type="text/javascript">\n'; sed 's#</script#<\\/script#g' "$js"; printf '\n</script>\n'
  done
  printf '<style>\ntable { border-spacing: 15px; }\n</style>\n</head>\n<body>\n{plot_divs}\n</body>\n</html>\n'
} > "$out"
echo "wrote $out ($(wc -c < "$out") bytes)"
