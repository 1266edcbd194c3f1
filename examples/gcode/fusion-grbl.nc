%
(1001)
(Written in the style of Fusion 360's grbl post, safe retracts set to "clearance height")
(Machine)
(  vendor: Autodesk)
(T1  D=3.175 CR=0 - ZMIN=-2 - flat end mill)
G90 G94
G17
G21

(2D Contour1)
T1
S16000 M3
G54
G0 X-2 Y-2
Z15
G0 Z5
G1 Z-1 F600
G1 X0 Y0 F2400
X40
G3 X45 Y5 I0 J5
G1 Y25
G3 X40 Y30 I-5 J0
G1 X5
G3 X0 Y25 I0 J-5
G1 Y0
G1 Z-2 F600
G1 X20 Y15 F1800
G2 X20 Y15 I5 J0
G0 Z15
M5
M30
%
