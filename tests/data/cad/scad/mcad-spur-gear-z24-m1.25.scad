// Spur gear, 24 teeth, module 1.25 (MCAD's circular_pitch = 180*module = 225),
// pressure angle 20 deg, 6 mm thick with a 10 mm hub of 16 mm diameter and an
// 8 mm bore: MCAD involute_gears.scad gear(...). Tip diameter 32.5 mm.
use <MCAD/involute_gears.scad>
gear(number_of_teeth=24, circular_pitch=225, pressure_angle=20, clearance=0.2,
     gear_thickness=6, rim_thickness=6, rim_width=5, hub_thickness=10,
     hub_diameter=16, bore_diameter=8, circles=0, backlash=0, twist=0,
     involute_facets=0, flat=false, $fn=32);
