// Futaba S3003 hobby servo housing with its two drilled mounting ears and the
// output spline: MCAD servos.scad futabas3003(...).
use <MCAD/servos.scad>
futabas3003(position=[0,0,0], rotation=[0,0,0], $fn=48);
