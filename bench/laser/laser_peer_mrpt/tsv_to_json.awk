# A TSV file with a header row as a JSON array of objects: numbers stay numbers, "-" is null.
#   awk -f tsv_to_json.awk file.tsv
BEGIN { FS = "\t"; printf "[" }
NR == 1 { for (c = 1; c <= NF; c++) key[c] = $c; next }
{
  printf "%s\n  {", (NR > 2 ? "," : "")
  for (c = 1; c <= NF; c++) {
    value = $c
    if (value == "-") value = "null"
    else if (value !~ /^-?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?$/) { gsub(/["\\]/, "\\\\&", value); value = "\"" value "\"" }
    printf "%s\"%s\": %s", (c > 1 ? ", " : ""), key[c], value
  }
  printf "}"
}
END { print (NR > 1 ? "\n" : "") "]" }
