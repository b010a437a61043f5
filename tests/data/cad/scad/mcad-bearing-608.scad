// 608 ball bearing body (8 x 22 x 7 mm) with its two recessed side shields:
// MCAD bearing.scad bearing(...).
use <MCAD/bearing.scad>
bearing(pos=[0,0,0], angle=[0,0,0], model=608, outline=false, $fn=64);
