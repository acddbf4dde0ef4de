# Per log and method: medians over the repeated runs, real-time factor, and Waymark's mean
# translation error and wall time as ratios of each MRPT method's (below 1: Waymark is better).
#   awk -f summarize.awk runs.tsv > summary.tsv
# runs.tsv (header first): log method run status relations relations_used trans_mean trans_std
#   rot_mean rot_std wall_s cpu_s duration_s scans; "-" where a value does not exist (no relations).
BEGIN { FS = OFS = "\t" }
NR == 1 { next }
{
  key = $1 SUBSEP $2
  if (!(key in runs)) { order[++keys] = key; name[key] = $1 OFS $2 }
  runs[key]++
  relations[key] = $5; duration[key] = $13
  if ($4 != "ok") { failed[key]++; next }
  ok[key]++
  for (c = 6; c <= 12; c++) if ($c != "-") values[key, c] = values[key, c] " " $c
}
function median(list,   v, n, i, j, t) {
  n = split(list, v, " ")
  if (n == 0) return "-"
  for (i = 2; i <= n; i++)
    for (j = i; j > 1 && v[j - 1] + 0 > v[j] + 0; j--) { t = v[j]; v[j] = v[j - 1]; v[j - 1] = t }
  return n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
}
function extreme(list, want_max,   v, n, i, e) {
  n = split(list, v, " ")
  if (n == 0) return "-"
  e = v[1]
  for (i = 2; i <= n; i++) if (want_max ? v[i] + 0 > e + 0 : v[i] + 0 < e + 0) e = v[i]
  return e
}
function ratio(a, b) { return (a == "-" || b == "-" || b + 0 == 0) ? "-" : sprintf("%.3f", a / b) }
END {
  print "log", "method", "runs", "failed", "relations", "relations_used", "trans_mean", "trans_std",
        "rot_mean", "rot_std", "wall_s", "wall_min", "wall_max", "cpu_s", "duration_s", "rtf",
        "waymark_trans_ratio", "waymark_wall_ratio"
  for (i = 1; i <= keys; i++) {
    key = order[i]
    for (c = 6; c <= 12; c++) med[key, c] = median(values[key, c])
  }
  for (i = 1; i <= keys; i++) {
    key = order[i]; split(key, part, SUBSEP)
    w = part[1] SUBSEP "waymark"
    mine = part[2] == "waymark" || !(w in runs)
    wall = med[key, 11]
    print name[key], runs[key], failed[key] + 0, relations[key], med[key, 6], med[key, 7],
          med[key, 8], med[key, 9], med[key, 10], wall, extreme(values[key, 11], 0),
          extreme(values[key, 11], 1), med[key, 12], duration[key],
          wall == "-" ? "-" : sprintf("%.1f", duration[key] / wall),
          mine ? "-" : ratio(med[w, 7], med[key, 7]), mine ? "-" : ratio(med[w, 11], wall)
  }
}
