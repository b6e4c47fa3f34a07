from ._common import floats as floats
