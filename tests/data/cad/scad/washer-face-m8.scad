// Not a part on its own: the washer face of an M8 nut (ISO 4032 d_w 11.6 mm)
// as a second body, 0.6 mm high from z = -0.4 to z = 0.2, bored 8.8 mm (the
// countersink of the thread). make-cad-data.sh writes it into one STL with
// mcad-hex-nut-m8.stl without a union: two closed shells that overlap by
// 0.2 mm (hex-nut-m8-two-shells.stl).
$fn = 48;
translate([0, 0, -0.4])
  difference() {
    cylinder(d=11.6, h=0.6);
    translate([0, 0, -1]) cylinder(d=8.8, h=2.6);
  }
