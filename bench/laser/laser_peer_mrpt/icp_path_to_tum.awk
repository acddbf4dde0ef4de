# Stamps icp-slam's estimated path with the CARMEN stamps of the scans, as a TUM trajectory.
#   awk -f icp_path_to_tum.awk stamps.txt log_estimated_path.txt > trajectory.txt
# icp-slam writes "step x y yaw" after every rawlog entry; carmen_for_mrpt.sh's rawlog holds per
# laser line an odometry entry then the scan, so the pose after scan k (0-based) is step 2k + 1,
# and stamps.txt lists the scans' stamps in rawlog order.
BEGIN { print "# t x y z qx qy qz qw" }
NR == FNR { stamp[scans++] = $1; next }
{ steps++ }
$1 % 2 == 1 {
  k = ($1 - 1) / 2
  printf "%s %s %s 0 0 0 %.9f %.9f\n", stamp[k], $2, $3, sin($4 / 2), cos($4 / 2)
}
END {
  if (steps != 2 * scans) {
    printf "icp_path_to_tum: %d path steps for %d scans (expected %d)\n", steps, scans, 2 * scans > "/dev/stderr"
    exit 1
  }
}
