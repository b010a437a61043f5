// NEMA 17 stepper motor body, short (33 mm) variant: a 42.2 mm square block
// with chamfered edges, four 4 mm M3 mounting holes 4.5 mm deep, a 22 mm
// centring boss and a 5 mm shaft with a flat: MCAD stepper.scad motor(...).
include <MCAD/stepper.scad>
motor(model=Nema17, size=NemaShort, dualAxis=false, pos=[0,0,0], orientation=[0,0,0], $fn=48);
