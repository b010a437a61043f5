// M8 hex nut: MCAD metric_fastners.scad flat_nut(dia=8) with its default
// apply_chamfer=true (a rounded chamfer on the lower hexagon corners).
// Width across corners e = 1.8*dia = 14.4 mm, height m = 0.8*dia = 6.4 mm,
// plain bore of the nominal diameter 8 mm (no thread).
use <MCAD/metric_fastners.scad>
flat_nut(8, $fn=48);
