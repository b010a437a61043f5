// Machined block 40 x 30 x 12 mm with its four vertical edges rounded to
// R3: MCAD boxes.scad roundedBox(...).
use <MCAD/boxes.scad>
roundedBox(size=[40, 30, 12], radius=3, sidesonly=true, $fn=48);
