# Time against n for self-collide and 1,000 queries (uniform scene), one line per manager.
# Data from make_table.py --plot-data. Usage:
#   gnuplot -e "data='time_vs_n.dat'; out='time_vs_n.png'" plot.gp
if (!exists("data")) data = 'time_vs_n.dat'
if (!exists("out")) out = 'time_vs_n.png'
set terminal pngcairo size 1400,560 font ",11" noenhanced
set output out
set logscale xy
set xlabel "objects (n)"
set ylabel "median CPU time per call (µs)"
set grid
set key top left
set datafile missing "NaN"
names = "cube DynamicAABBTree DynamicAABBTree_Array SaP SSaP IntervalTree SpatialHashing Naive"
set multiplot layout 1,2
set title "self-collide, counting callback (uniform scene)"
plot for [i=2:9] data index 0 using 1:i with linespoints lw (i == 2 ? 3 : 1) pt (i - 1) title word(names, i - 1)
set title "1,000 object-vs-manager queries (uniform scene)"
plot for [i=2:9] data index 1 using 1:i with linespoints lw (i == 2 ? 3 : 1) pt (i - 1) title word(names, i - 1)
unset multiplot
