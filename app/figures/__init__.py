"""The figures: pure functions, results in, plotly figures out (errors, innovations, sensors,
vehicle; app.figures.shared their common ground and each method's colour), and the 3-D scene's
geometry (app.figures.scene, app.figures.sensor_view)."""
