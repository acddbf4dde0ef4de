# summary.tsv (summarize.awk) as a markdown table.   awk -f table.awk summary.tsv > table.md
BEGIN { FS = "\t" }
NR == 1 { for (c = 1; c <= NF; c++) col[$c] = c; next }
function v(name) { return $col[name] }
function num(x, fmt) { return x == "-" ? "-" : sprintf(fmt, x) }
NR == 2 {
  print "| log | method | trans. error (m) | rot. error (deg) | wall (s) | CPU (s) | real-time factor | Waymark / this: trans. | Waymark / this: wall | relations used |"
  print "|---|---|---|---|---|---|---|---|---|---|"
}
{
  trans = v("trans_mean") == "-" ? "-" : sprintf("%.3f +- %.3f", v("trans_mean"), v("trans_std"))
  wall = num(v("wall_s"), "%.1f")
  if (v("runs") - v("failed") > 1) wall = wall sprintf(" [%.1f, %.1f]", v("wall_min"), v("wall_max"))
  if (v("failed") > 0) wall = wall sprintf(" (%d of %d runs failed)", v("failed"), v("runs"))
  used = v("relations") == "-" ? "no relations" : v("relations_used") " of " v("relations")
  printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", v("log"), v("method"), trans,
         num(v("rot_mean"), "%.2f"), wall, num(v("cpu_s"), "%.1f"), num(v("rtf"), "%.0fx"), v("waymark_trans_ratio"),
         v("waymark_wall_ratio"), used
  if (v("runs") + 0 > runs + 0) runs = v("runs")
}
END {
  if (NR > 1)
    printf "\nMedians over up to %d run(s) per row, [min, max] of the wall time; real-time factor = log duration / wall; CPU = user + system (Waymark: client + server).\n", runs
}
