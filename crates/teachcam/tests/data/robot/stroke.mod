MODULE stroke
  ! Written by teachcam: 12 moves, path tolerance 0.500 mm / 0.500 deg.
  ! time scale 1.00: the demonstration's own timing.
  ! Tool load 0.200 kg at (0.0, 0.0, 75.0) mm in tool0, assumed (0.2 kg at half the TCP offset; set --tool-mass and --tool-cog).
  PERS tooldata tTeachcam := [TRUE,[[0.000,0.000,150.000],[1.0000000,0.0000000,0.0000000,0.0000000]],[0.200,[0.000,0.000,75.000],[1,0,0,0],0,0,0]];
  PERS wobjdata wTeachcam := [FALSE,TRUE,"",[[350.000,0.000,150.000],[1.0000000,0.0000000,0.0000000,0.0000000]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget p0001 := [[2.955,33.659,15.000],[0.0359492,0.0000000,-0.9993536,0.0000000],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0002 := [[34.363,38.106,20.353],[0.0633684,0.0499209,-0.9963591,-0.0275825],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0003 := [[43.427,39.539,22.375],[0.0748291,0.0784030,-0.9932205,-0.0420312],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0004 := [[44.885,39.802,22.749],[0.0775799,0.0876263,-0.9920396,-0.0464808],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0005 := [[46.264,39.999,22.993],[0.0813193,0.1056531,-0.9895541,-0.0548381],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0006 := [[47.062,39.475,22.090],[0.0823090,0.1315975,-0.9856696,-0.0660519],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0007 := [[49.589,37.978,19.837],[0.0777103,0.1560876,-0.9817670,-0.0757055],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0008 := [[57.858,33.434,14.331],[0.0587406,0.1928268,-0.9755017,-0.0881122],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0009 := [[59.528,30.955,12.055],[0.0479064,0.2056873,-0.9731435,-0.0915943],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0010 := [[58.162,28.138,10.031],[0.0357235,0.2172422,-0.9709167,-0.0940764],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0011 := [[56.026,26.611,9.168],[0.0292510,0.2224734,-0.9698677,-0.0949035],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p0012 := [[48.626,23.344,7.834],[0.0158120,0.2317337,-0.9679365,-0.0956472],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST speeddata v0002 := [193.018,43.566,5000,1000];
  CONST speeddata v0003 := [93.966,39.050,5000,1000];
  CONST speeddata v0004 := [45.846,36.678,5000,1000];
  CONST speeddata v0005 := [21.208,35.015,5000,1000];
  CONST speeddata v0006 := [13.146,32.714,5000,1000];
  CONST speeddata v0007 := [37.018,30.948,5000,1000];
  CONST speeddata v0008 := [65.544,29.994,5000,1000];
  CONST speeddata v0009 := [56.346,29.795,5000,1000];
  CONST speeddata v0010 := [55.926,29.426,5000,1000];
  CONST speeddata v0011 := [82.905,28.976,5000,1000];
  CONST speeddata v0012 := [122.973,28.278,5000,1000];
  CONST zonedata zTeachcam := [FALSE,0.500,0.500,0.500,0.500,0.500,0.500];

  PROC main()
    ! Configuration monitored: every robconf is the quadrant the checked joints take there; SingArea \Off: axis 5 stays clear of the wrist singularity.
    ConfJ \On;
    ConfL \On;
    SingArea \Off;
    ! Stroke 1 of 1: frames 0-29.
    MoveJ p0001, v100, fine, tTeachcam\WObj:=wTeachcam;
    path_1;
  ENDPROC

  PROC path_1()
    MoveL p0002, v0002, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0003, v0003, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0004, v0004, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0005, v0005, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0006, v0006, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0007, v0007, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0008, v0008, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0009, v0009, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0010, v0010, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0011, v0011, zTeachcam, tTeachcam\WObj:=wTeachcam;
    MoveL p0012, v0012, fine, tTeachcam\WObj:=wTeachcam;
  ENDPROC
ENDMODULE
