"""Files in and out: thruster model files (``modelfile``), bench data (``bench``), logs (``logs``:
CSV/Parquet, ROS bags, ArduSub), export to UUV Simulator (``export``), atomic writes (``atomic``)."""
