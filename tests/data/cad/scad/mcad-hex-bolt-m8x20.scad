// M8 x 20 hex bolt: MCAD metric_fastners.scad bolt(dia=8, len=20) with its
// default apply_chamfer=true. Head across corners e = 1.8*dia = 14.4 mm,
// head height k = 0.7*dia = 5.6 mm; plain 8 mm shank (no thread) from the
// head's bearing face (z = 0) to z = 20 through the head.
use <MCAD/metric_fastners.scad>
bolt(8, 20, $fn=48);
